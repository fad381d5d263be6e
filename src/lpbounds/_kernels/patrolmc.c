/* The patrol's trajectories, compiled ahead of time: the greedy policy pi_s acted out one
 * state at a time (lpbounds.patrol.greedy_mc: its actions, the Monte Carlo returns, Table 1's
 * trajectories) and the simulator of Table 1 (lpbounds.patrol.simulation.simulate).
 *
 * No random numbers are drawn here: the alert sequences come from numpy's generator
 * (lpbounds.patrol.simulation.alert_sequence) and are passed in.
 *
 * The arithmetic is term for term that of the numba kernels these replace:
 * Q(x, u) = R_u(x) + lambda * sum_l p_l w(i(f(x, u, Y_l))), the sum from 0.0 in outcome order
 * (lpbounds.dp.greedy_policy's), the tie rule of GREEDY_TIE_RTOL (the lowest action within
 * tie_rtol * max(1, |max Q|) of the best), the return g += disc * r, the control variate
 * g -= disc * lambda * (w(x') - E w(x')), disc *= lambda; no fused multiply-add
 * (-ffp-contract=off, setup.py), so every number is the numba kernels' bit for bit
 * (benchmarks/fingerprints_patrol.py, tests/patrol/test_greedy_mc.py).
 *
 * Bounds: the model's tables (sizes, station positions, index weights) are checked exactly
 * against their definition and the start states and outcomes against the model, so every
 * state and partition index formed is one (the model maps states to states); the
 * simulator, which reads a caller's successor table, checks every index it reads.
 * Each function releases the GIL; greedy_returns works on a range of paths, so that
 * lpbounds.patrol.greedy_mc runs one range per thread.
 */
#include "patrol.h"

/* The model's constants as greedy_mc._Kernel.args() gives them, and the values w. */
typedef struct {
    PModel pm;
    int64_t allow_empty;
    const double *probs; /* (m + 1,) */
    const double *inc;   /* (D,) */
    double rho, discount, tie_rtol;
    const double *lower; /* (n_partitions,) */
} Mt;

#define MT_BUFS 8

/* mt = (cfg, station_pos, stations, w_travel, w_loiter, probs, inc, rho, discount, tie_rtol)
 * and lower, into b[0..7], checked. */
static int load_mt(PyObject *o_mt, PyObject *o_lower, Buf *b, Mt *mt) {
    PyObject *o_cfg, *o_sp, *o_st, *o_wt, *o_wl, *o_p, *o_inc;
    if (!PyTuple_Check(o_mt) || PyTuple_GET_SIZE(o_mt) != 10) {
        PyErr_SetString(PyExc_TypeError, "mt: expected the tuple of greedy_mc._Kernel.args()");
        return -1;
    }
    if (!PyArg_ParseTuple(o_mt, "OOOOOOOddd", &o_cfg, &o_sp, &o_st, &o_wt, &o_wl, &o_p, &o_inc,
                          &mt->rho, &mt->discount, &mt->tie_rtol))
        return -1;
    if (get(o_cfg, &b[0], "mt cfg", 1, 'i', 8, 0, 0) ||
        get(o_sp, &b[1], "mt station_pos", 1, 'i', 8, 0, 0) ||
        get(o_st, &b[2], "mt stations", 1, 'i', 8, 0, 0) ||
        get(o_wt, &b[3], "mt w_travel", 1, 'i', 8, 0, 0) ||
        get(o_wl, &b[4], "mt w_loiter", 2, 'i', 8, 0, 0) ||
        get(o_p, &b[5], "mt probs", 1, 'f', 0, 0, 0) ||
        get(o_inc, &b[6], "mt inc", 1, 'f', 0, 0, 0) ||
        get(o_lower, &b[7], "lower", 1, 'f', 0, 0, 0) || check_shape(&b[0], "mt cfg", 8, -1))
        return -1;
    const int64_t *cfg = b[0].b.buf;
    PModel *pm = &mt->pm;
    if (pmodel_sizes(pm, cfg[0], b[2].b.shape[0], cfg[1], cfg[2]))
        return -1;
    const int64_t want[7] = {pm->N,        pm->D,       pm->gamma,  pm->radix,
                             pm->n_travel, pm->tb_size, pm->lb_size};
    for (int f = 0; f < 7; f++)
        if (cfg[f] != want[f]) {
            PyErr_Format(PyExc_ValueError, "mt cfg[%d] = %lld, expected %lld", f,
                         (long long)cfg[f], (long long)want[f]);
            return -1;
        }
    mt->allow_empty = cfg[7];
    if (check_shape(&b[1], "mt station_pos", pm->N, -1) ||
        check_shape(&b[3], "mt w_travel", pm->m, -1) ||
        check_shape(&b[4], "mt w_loiter", pm->m, pm->m) ||
        check_shape(&b[5], "mt probs", pm->m + 1, -1) || check_shape(&b[6], "mt inc", pm->D, -1) ||
        check_shape(&b[7], "lower", pm->n_partitions, -1) ||
        pmodel_stations(pm, b[1].b.buf, b[2].b.buf) ||
        pmodel_weights(pm, b[3].b.buf, b[4].b.buf, pm->m, "mt w_travel", "mt w_loiter"))
        return -1;
    pm->w_travel = b[3].b.buf;
    pm->w_loiter = b[4].b.buf;
    mt->probs = b[5].b.buf;
    mt->inc = b[6].b.buf;
    mt->lower = b[7].b.buf;
    return 0;
}

/* The current state and, per action a, its successors by outcome (succ[a]), the components
 * of the no-alert successor (nl, nw, nd, ntau), the Q-values, the successors' values wn[a]
 * and their expectation ev[a] (greedy_mc._buffers). */
typedef struct {
    int64_t cur[3];
    int64_t tau[PATROL_MMAX];
    int64_t succ[3][PATROL_MMAX + 1];
    int64_t nl[3], nw[3], nd[3];
    int64_t ntau[3][PATROL_MMAX];
    double q[3];
    double wn[3][PATROL_MMAX + 1];
    double ev[3];
} GBuf;

/* decode state x into action a's successor slots; it becomes succ[a][0] */
Py_LOCAL_INLINE(void) decode_into(const Mt *mt, int64_t x, int a, GBuf *bf) {
    bf->succ[a][0] = x;
#define NTAU_A(j) bf->ntau[a][j]
    DECODE_ONE(&mt->pm, x, bf->nl[a], bf->nw[a], bf->nd[a], NTAU_A);
#undef NTAU_A
}

/* move to the successor of action a under outcome y (y = -1: the decoded state itself) */
Py_LOCAL_INLINE(int64_t) advance_to(GBuf *bf, int a, int64_t y, int64_t m) {
    bf->cur[0] = bf->nl[a];
    bf->cur[1] = bf->nw[a];
    bf->cur[2] = bf->nd[a];
    memcpy(bf->tau, bf->ntau[a], sizeof(int64_t) * (size_t)m);
    if (y < 0)
        return -1;
    if (y > 0 && bf->succ[a][y] != bf->succ[a][0])
        bf->tau[y - 1] = 1;
    return bf->succ[a][y];
}

Py_LOCAL_INLINE(void) set_state(const Mt *mt, int64_t x, GBuf *bf) {
    decode_into(mt, x, 0, bf);
    advance_to(bf, 0, -1, mt->pm.m);
}

/* lambda sum_l p_l lower[i(f(x, a, Y_l))] in outcome order; fills action a's slots. Only
 * the no-alert successor is decoded: the successor under y >= 1 differs from it exactly when
 * the alert at station y - 1 is new (tau' = 1: A' gets the bit, taubar' = max(taubar, 1)). */
Py_LOCAL_INLINE(double) q_value(const Mt *mt, int a, GBuf *bf) {
    const PModel *pm = &mt->pm;
    int64_t m = pm->m;
#define TAU_CUR(j) bf->tau[j]
#define SUCC_A(j) bf->succ[a][j]
    SUCCESSORS_ONE(pm, bf->cur[0], bf->cur[1], bf->cur[2], TAU_CUR, a, SUCC_A);
#undef TAU_CUR
#undef SUCC_A
    decode_into(mt, bf->succ[a][0], a, bf);
    int64_t acode = 0, tb = 0;
    for (int64_t j = 0; j < m; j++) {
        acode = 2 * acode + (bf->ntau[a][j] > 0 ? 1 : 0);
        if (bf->ntau[a][j] > tb)
            tb = bf->ntau[a][j];
    }
    double acc = 0.0;
    for (int64_t y = 0; y <= m; y++) {
        int64_t ay = acode, tby = tb;
        if (y > 0 && bf->succ[a][y] != bf->succ[a][0]) {
            ay = acode | ((int64_t)1 << (m - y));
            tby = 1 > tb ? 1 : tb;
        }
        int64_t part = key_index(bf->nl[a], bf->nw[a], bf->nd[a], ay, tby, pm->station_pos, pm->N,
                                 pm->D, pm->gamma, pm->tb_size, pm->lb_size, m);
        bf->wn[a][y] = mt->lower[part];
        acc += mt->probs[y] * bf->wn[a][y];
    }
    bf->ev[a] = acc;
    return mt->discount * acc;
}

/* the greedy action at the current state and its reward R_u(x) into *reward; fills the
 * successor slots of every allowed action (greedy_mc._greedy_step) */
Py_LOCAL_INLINE(int) greedy_step(const Mt *mt, GBuf *bf, double *reward) {
    const PModel *pm = &mt->pm;
    int64_t l = bf->cur[0], d = bf->cur[2], k = pm->station_pos[l];
    int64_t tbar = 0;
    for (int64_t j = 0; j < pm->m; j++)
        if (bf->tau[j] > tbar)
            tbar = bf->tau[j];
    double pen = -mt->rho * (double)(pm->gamma < tbar ? pm->gamma : tbar);
    int n_act = 2;
    if (k >= 0 && d < pm->D && (d >= 1 || bf->tau[k] > 0 || mt->allow_empty != 0))
        n_act = 3;
    double best = -INFINITY;
    for (int a = 0; a < n_act; a++) {
        double r = a == 2 ? pen + mt->inc[d] : pen;
        bf->q[a] = r + q_value(mt, a, bf);
        best = bf->q[a] > best ? bf->q[a] : best;
    }
    double ab = fabs(best);
    double thr = best - mt->tie_rtol * (ab > 1.0 ? ab : 1.0);
    int best_a = 0;
    for (int a = n_act - 1; a >= 0; a--)
        if (bf->q[a] >= thr)
            best_a = a;
    *reward = best_a == 2 ? pen + mt->inc[d] : pen;
    return best_a;
}

/* a start state: 0 <= x < n_states (ValueError naming it) */
static int state_ok(const Mt *mt, long long x, const char *name, Py_ssize_t i) {
    if (x < 0 || x >= mt->pm.n_states) {
        if (i >= 0)
            PyErr_Format(PyExc_ValueError, "%s[%zd] = %lld is not a state 0..%lld", name, i, x,
                         (long long)(mt->pm.n_states - 1));
        else
            PyErr_Format(PyExc_ValueError, "%s = %lld is not a state 0..%lld", name, x,
                         (long long)(mt->pm.n_states - 1));
        return -1;
    }
    return 0;
}

/* outcomes[i], start <= i < end: in 0..m (ValueError naming the first not) */
static int outcomes_ok(const int64_t *y, Py_ssize_t start, Py_ssize_t end, int64_t m) {
    for (Py_ssize_t i = start; i < end; i++)
        if (y[i] < 0 || y[i] > m) {
            PyErr_Format(PyExc_ValueError, "outcomes (flat) [%zd] = %lld is not an outcome 0..%lld",
                         i, (long long)y[i], (long long)m);
            return -1;
        }
    return 0;
}

PyDoc_STRVAR(greedy_actions_doc,
             "greedy_actions(xs, lower, mt, out, start, end)\n\n"
             "out[i] (int8): the greedy action at state xs[i], start <= i < end. Releases the GIL.");

static PyObject *greedy_actions(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_xs, *o_lower, *o_mt, *o_out;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOOnn", &o_xs, &o_lower, &o_mt, &o_out, &start, &end))
        return NULL;
    Buf b[MT_BUFS + 2];
    memset(b, 0, sizeof b);
    Mt mt;
    PyObject *res = NULL;
    if (load_mt(o_mt, o_lower, b, &mt) || get(o_xs, &b[8], "xs", 1, 'i', 8, 0, 0) ||
        get(o_out, &b[9], "out", 1, 'i', 1, 1, 0) ||
        check_shape(&b[9], "out", b[8].b.shape[0], -1) ||
        check_range(start, end, b[8].b.shape[0]))
        goto done;
    const int64_t *xs = b[8].b.buf;
    for (Py_ssize_t i = start; i < end; i++)
        if (state_ok(&mt, xs[i], "xs", i))
            goto done;
    int8_t *out = b[9].b.buf;
    Py_BEGIN_ALLOW_THREADS
    GBuf bf;
    memset(&bf, 0, sizeof bf);
    for (Py_ssize_t i = start; i < end; i++) {
        double r;
        set_state(&mt, xs[i], &bf);
        out[i] = (int8_t)greedy_step(&mt, &bf, &r);
    }
    Py_END_ALLOW_THREADS
    res = Py_NewRef(Py_None);
done:
    release(b, MT_BUFS + 2);
    return res;
}

/* One path of H steps from x0 under y: its discounted return (greedy_mc._path_return),
 * minus (cv) the control variate; with states and actions (not NULL), the trajectory
 * states[0..H], actions[0..H) (greedy_mc._trajectory_kernel). */
static double path_run(const Mt *mt, int64_t x0, const int64_t *y, Py_ssize_t horizon, int cv,
                       GBuf *bf, int64_t *states, int64_t *actions) {
    double lam = mt->discount;
    set_state(mt, x0, bf);
    double g = 0.0, disc = 1.0;
    int64_t x = x0;
    for (Py_ssize_t t = 0; t < horizon; t++) {
        double r;
        if (states)
            states[t] = x;
        int a = greedy_step(mt, bf, &r);
        if (actions)
            actions[t] = a;
        int64_t yt = y[t];
        g += disc * r;
        if (cv)
            g -= disc * lam * (bf->wn[a][yt] - bf->ev[a]);
        disc *= lam;
        x = advance_to(bf, a, yt, mt->pm.m);
    }
    if (states)
        states[horizon] = x;
    return g;
}

/* mt and lower into b[0..7], the outcomes (ndim dimensions) into b[8], x0 a state */
static int open_paths(PyObject *o_mt, PyObject *o_lower, PyObject *o_y, int ndim, long long x0,
                      Buf *b, Mt *mt) {
    if (load_mt(o_mt, o_lower, b, mt) || get(o_y, &b[8], "outcomes", ndim, 'i', 8, 0, 0) ||
        state_ok(mt, x0, "x0", -1))
        return -1;
    return 0;
}

PyDoc_STRVAR(greedy_returns_doc,
             "greedy_returns(x0, outcomes, lower, mt, cv, out, start, end)\n\n"
             "out[p]: the discounted return of path p from x0 under outcomes[p] (int64, (P, H)),"
             " minus (cv) the control variate, for start <= p < end. Releases the GIL.");

static PyObject *greedy_returns(PyObject *Py_UNUSED(self), PyObject *args) {
    long long x0;
    PyObject *o_y, *o_lower, *o_mt, *o_out;
    int cv;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "LOOOpOnn", &x0, &o_y, &o_lower, &o_mt, &cv, &o_out, &start,
                          &end))
        return NULL;
    Buf b[MT_BUFS + 2];
    memset(b, 0, sizeof b);
    Mt mt;
    PyObject *res = NULL;
    if (open_paths(o_mt, o_lower, o_y, 2, x0, b, &mt) ||
        get(o_out, &b[9], "out", 1, 'f', 0, 1, 0) ||
        check_shape(&b[9], "out", b[8].b.shape[0], -1) ||
        check_range(start, end, b[8].b.shape[0]) ||
        outcomes_ok(b[8].b.buf, start * b[8].b.shape[1], end * b[8].b.shape[1], mt.pm.m))
        goto done;
    Py_ssize_t horizon = b[8].b.shape[1];
    const int64_t *y = b[8].b.buf;
    double *out = b[9].b.buf;
    Py_BEGIN_ALLOW_THREADS
    GBuf bf;
    memset(&bf, 0, sizeof bf);
    for (Py_ssize_t p = start; p < end; p++)
        out[p] = path_run(&mt, x0, y + p * horizon, horizon, cv, &bf, NULL, NULL);
    Py_END_ALLOW_THREADS
    res = Py_NewRef(Py_None);
done:
    release(b, MT_BUFS + 2);
    return res;
}

PyDoc_STRVAR(greedy_trajectory_doc,
             "greedy_trajectory(x0, outcomes, lower, mt, states, actions)\n\n"
             "One trajectory of pi_s from x0 under outcomes (int64, (T,)): states[t] "
             "(t = 0..T) and actions[t] (t < T), int64. Releases the GIL.");

static PyObject *greedy_trajectory(PyObject *Py_UNUSED(self), PyObject *args) {
    long long x0;
    PyObject *o_y, *o_lower, *o_mt, *o_states, *o_actions;
    if (!PyArg_ParseTuple(args, "LOOOOO", &x0, &o_y, &o_lower, &o_mt, &o_states, &o_actions))
        return NULL;
    Buf b[MT_BUFS + 3];
    memset(b, 0, sizeof b);
    Mt mt;
    PyObject *res = NULL;
    if (open_paths(o_mt, o_lower, o_y, 1, x0, b, &mt) ||
        get(o_states, &b[9], "states", 1, 'i', 8, 1, 0) ||
        get(o_actions, &b[10], "actions", 1, 'i', 8, 1, 0) ||
        check_shape(&b[9], "states", b[8].b.shape[0] + 1, -1) ||
        check_shape(&b[10], "actions", b[8].b.shape[0], -1) ||
        outcomes_ok(b[8].b.buf, 0, b[8].b.shape[0], mt.pm.m))
        goto done;
    Py_BEGIN_ALLOW_THREADS
    GBuf bf;
    memset(&bf, 0, sizeof bf);
    path_run(&mt, x0, b[8].b.buf, b[8].b.shape[0], 0, &bf, b[9].b.buf, b[10].b.buf);
    Py_END_ALLOW_THREADS
    res = Py_NewRef(Py_None);
done:
    release(b, MT_BUFS + 3);
    return res;
}

/* ------------------------------------------------------------------ the simulator */
/* counts: 0 arrivals, 1 merged, 2 absorbed, 3 loiter steps, 4 mismatches, 5 first mismatch
 * step, 6 empty loiter steps, 7 unused */
enum { C_ARR, C_MERGED, C_ABSORBED, C_LOITER, C_MISMATCH, C_FIRST, C_EMPTY, C_LEN };
/* bad_a of a step whose action is not one (else bad_a is the successor that is no state) */
#define BAD_ACTION INT64_MIN

PyDoc_STRVAR(simulate_doc,
             "simulate(x0, policy, successors, comps, stations, N, Gamma, outcomes, check, "
             "r_station, r_arrival, r_start, r_visit, r_loiters, r_done, r_merged, "
             "r_merged_delay, counts) -> (n_rec, n_unserviced, final_state)\n\n"
             "One trajectory under policy and the outcomes (lpbounds.patrol.simulation); the "
             "records of the serviced alerts into the r_ arrays (int64, r_done bool, n_steps + 1"
             " each; r_loiters, r_done, r_merged, r_merged_delay zeroed by the caller), the "
             "counts (int64, 8) as the module says. Releases the GIL.");

static PyObject *simulate(PyObject *Py_UNUSED(self), PyObject *args) {
    long long x0, n_nodes, gamma;
    int check;
    PyObject *o_pol, *o_succ, *o_comps, *o_st, *o_y, *o_r[8], *o_counts;
    if (!PyArg_ParseTuple(args, "LOOOOLLOpOOOOOOOOO", &x0, &o_pol, &o_succ, &o_comps, &o_st,
                          &n_nodes, &gamma, &o_y, &check, &o_r[0], &o_r[1], &o_r[2], &o_r[3],
                          &o_r[4], &o_r[5], &o_r[6], &o_r[7], &o_counts))
        return NULL;
    static const char *const r_names[8] = {"r_station", "r_arrival", "r_start", "r_visit",
                                           "r_loiters", "r_done", "r_merged", "r_merged_delay"};
    Buf b[14];
    memset(b, 0, sizeof b);
    PyObject *res = NULL;
    int64_t *scratch = NULL;
    if (get(o_pol, &b[0], "policy", 1, 'i', 8, 0, 0) ||
        get(o_succ, &b[1], "successors", 3, 'i', S_IDX, 0, 0) ||
        get(o_comps, &b[2], "comps", 2, 'i', S_IDX, 0, 0) ||
        get(o_st, &b[3], "stations", 1, 'i', 8, 0, 0) ||
        get(o_y, &b[4], "outcomes", 1, 'i', 8, 0, 0) ||
        get(o_counts, &b[5], "counts", 1, 'i', 8, 1, 0))
        goto done;
    for (int i = 0; i < 8; i++)
        if (get(o_r[i], &b[6 + i], r_names[i], 1, i == 5 ? 'b' : 'i', 8, 1, 0))
            goto done;
    Py_ssize_t n = b[1].b.shape[0], A = b[1].b.shape[1], L = b[1].b.shape[2];
    Py_ssize_t m = b[3].b.shape[0], n_steps = b[4].b.shape[0];
    if (check_shape(&b[0], "policy", n, -1) || check_shape(&b[2], "comps", n, 3 + m) ||
        check_shape(&b[5], "counts", C_LEN + 1, -1))
        goto done;
    for (int i = 0; i < 8; i++)
        if (check_shape(&b[6 + i], r_names[i], n_steps + 1, -1))
            goto done;
    if (n_nodes < 1 || m < 1 || x0 < 0 || x0 >= n) {
        PyErr_Format(PyExc_ValueError, "simulate: N = %lld (>= 1), %zd stations (>= 1), start "
                     "%lld (a state 0..%zd)", n_nodes, m, x0, n - 1);
        goto done;
    }
    const int64_t *y = b[4].b.buf;
    for (Py_ssize_t t = 0; t < n_steps; t++)
        if (y[t] < 0 || y[t] > m || y[t] >= L) {
            PyErr_Format(PyExc_ValueError, "outcomes[%zd] = %lld is not an outcome 0..%zd", t,
                         (long long)y[t], (m < L - 1 ? m : L - 1));
            goto done;
        }
    /* per station: pending, arrival, first visit, merged count, merged arrivals; nxt */
    scratch = (int64_t *)calloc((size_t)(6 * m + 3), sizeof(int64_t));
    if (!scratch) {
        PyErr_NoMemory();
        goto done;
    }
    int64_t *pend = scratch, *arr = scratch + m, *visit = scratch + 2 * m;
    int64_t *mcount = scratch + 3 * m, *msum = scratch + 4 * m, *nxt = scratch + 5 * m;
    const int64_t *policy = b[0].b.buf, *stations = b[3].b.buf;
    const Buf *succ = &b[1], *comps = &b[2];
    int64_t *counts = b[5].b.buf;
    int64_t *r_station = b[6].b.buf, *r_arrival = b[7].b.buf, *r_start = b[8].b.buf;
    int64_t *r_visit = b[9].b.buf, *r_loiters = b[10].b.buf, *r_merged = b[12].b.buf;
    int64_t *r_merged_delay = b[13].b.buf;
    char *r_done = b[11].b.buf;
    Py_ssize_t width = 3 + m;
    int64_t n_rec = 0, run = -1, x = x0, bad_x = -1, bad_a = 0, bad_t = -1;
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t j = 0; j < m; j++)
        visit[j] = -1;
    for (int i = 0; i < C_LEN + 1; i++)
        counts[i] = 0;
    counts[C_FIRST] = -1;
    for (Py_ssize_t t = 0; t < n_steps; t++) {
        int64_t l = buf_int(comps, x * width), w = buf_int(comps, x * width + 1);
        int64_t d = buf_int(comps, x * width + 2);
        int64_t a = policy[x], yt = y[t];
        if (a < 0 || a >= A) {
            bad_x = x, bad_a = BAD_ACTION, bad_t = t;
            break;
        }
        int64_t jl = -1;
        for (Py_ssize_t j = 0; j < m; j++)
            if (stations[j] == l)
                jl = j;
        if (jl >= 0 && pend[jl] && visit[jl] < 0) /* first visit with an alert pending */
            visit[jl] = t;
        if (a == 2) {
            counts[C_LOITER] += 1;
            if (d == 0 && jl >= 0 && pend[jl]) {
                r_station[n_rec] = jl;
                r_arrival[n_rec] = arr[jl];
                r_start[n_rec] = t;
                r_visit[n_rec] = visit[jl];
                r_merged[n_rec] = mcount[jl];
                r_merged_delay[n_rec] = mcount[jl] * t - msum[jl];
                run = n_rec;
                n_rec += 1;
                pend[jl] = 0;
                mcount[jl] = 0;
                msum[jl] = 0;
            }
            if (run >= 0)
                r_loiters[run] += 1;
            else
                counts[C_EMPTY] += 1;
        } else {
            if (run >= 0)
                r_done[run] = 1;
            run = -1;
        }
        if (yt > 0) {
            int64_t j = yt - 1;
            counts[C_ARR] += 1;
            if (a == 2 && jl == j) {
                counts[C_ABSORBED] += 1;
            } else if (pend[j]) {
                counts[C_MERGED] += 1;
                mcount[j] += 1;
                msum[j] += t;
            } else {
                pend[j] = 1;
                arr[j] = t;
                visit[j] = -1;
            }
        }
        int64_t xn = buf_int(succ, ((Py_ssize_t)x * A + a) * L + yt);
        if (xn < 0 || xn >= n) {
            bad_x = x, bad_a = xn, bad_t = t;
            break;
        }
        if (check) { /* the specification's f on components, independently of the table */
            int64_t u = a == 0 ? 1 : (a == 1 ? -1 : 0);
            if (u != 0) {
                nxt[0] = floor_mod(l + w * u, n_nodes);
                nxt[1] = w * u;
                nxt[2] = 0;
            } else {
                nxt[0] = l;
                nxt[1] = 1;
                nxt[2] = d + 1;
            }
            for (Py_ssize_t j = 0; j < m; j++) {
                int64_t tj = buf_int(comps, x * width + 3 + j), v;
                if (u == 0 && j == jl)
                    v = 0;
                else if (tj > 0)
                    v = gamma < tj + 1 ? gamma : tj + 1;
                else if (yt == j + 1)
                    v = 1;
                else
                    v = 0;
                nxt[3 + j] = v;
                /* the pending bookkeeping must agree with the model's delays */
                int64_t due = t + 1 - arr[j];
                if ((pend[j] != 0) != (v > 0) || (pend[j] && v != (gamma < due ? gamma : due)))
                    nxt[3 + j] = -1;
            }
            int mismatch = 0;
            for (Py_ssize_t k = 0; k < width; k++)
                if (buf_int(comps, xn * width + k) != nxt[k])
                    mismatch = 1;
            if (mismatch) {
                counts[C_MISMATCH] += 1;
                if (counts[C_FIRST] < 0)
                    counts[C_FIRST] = t;
            }
        }
        x = xn;
    }
    Py_END_ALLOW_THREADS
    if (bad_t >= 0) {
        if (bad_a == BAD_ACTION)
            PyErr_Format(PyExc_ValueError, "step %lld: policy[%lld] = %lld is not an action "
                         "0..%zd", (long long)bad_t, (long long)bad_x, (long long)policy[bad_x],
                         A - 1);
        else
            PyErr_Format(PyExc_ValueError, "step %lld: successors[%lld, %lld, %lld] = %lld is "
                         "not a state 0..%zd", (long long)bad_t, (long long)bad_x,
                         (long long)policy[bad_x], (long long)y[bad_t], (long long)bad_a, n - 1);
        goto done;
    }
    int64_t n_unserviced = 0;
    for (Py_ssize_t j = 0; j < m; j++)
        n_unserviced += pend[j] != 0;
    res = Py_BuildValue("LLL", (long long)n_rec, (long long)n_unserviced, (long long)x);
done:
    free(scratch);
    release(b, 14);
    return res;
}

static PyMethodDef methods[] = {
    {"greedy_actions", greedy_actions, METH_VARARGS, greedy_actions_doc},
    {"greedy_returns", greedy_returns, METH_VARARGS, greedy_returns_doc},
    {"greedy_trajectory", greedy_trajectory, METH_VARARGS, greedy_trajectory_doc},
    {"simulate", simulate, METH_VARARGS, simulate_doc},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "patrolmc",
    "The patrol's trajectories (the greedy policy on the fly, its Monte Carlo returns, the "
    "simulator of Table 1), compiled ahead of time (see lpbounds.patrol.greedy_mc).",
    -1, methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit_patrolmc(void) { return PyModule_Create(&module); }

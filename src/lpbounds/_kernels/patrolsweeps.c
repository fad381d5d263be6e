/* The patrol's matrix-free sweeps and passes (lpbounds.patrol.sweeps), compiled ahead of time,
 * and the model's decoder, successors and partition key (lpbounds.patrol.model, .partitions).
 *
 * The walk (lpbounds.patrol.sweeps explains it): the states in index order, a *row* of
 * Gamma + 1 states differing in the fast digit, a cursor (plane and delays) carried from
 * row to row, the row's successors per action and outcome set up once (rr, gl), the sums
 * of a row formed per outcome in order, the two travel planes of a node taking the same
 * sums. Work is split into ``nchunks`` chunks of whole rows, as before the port; each
 * function here takes a range of chunks [c0, c1) and releases the GIL, and
 * lpbounds.patrol.sweeps runs one range per thread.
 *
 * The arithmetic is term for term that of the numba kernels these replace (and of the
 * array path, lpbounds.rows.PostDecisionRows): acc = 0.0; acc += p_o * v[succ_o] over the
 * outcomes in order; q = R + lambda * acc; the loiter's reward (pen + inc) formed first;
 * the first maximising action kept (strict >); the extremes by strict < and > from +inf,
 * -inf (numba's min and max); no fused multiply-add (-ffp-contract=off, setup.py) and no
 * reassociation. Per-chunk statistics go to the caller's arrays, reduced in Python as
 * before, so every number is the numba kernels' bit for bit (benchmarks/fingerprints_patrol.py,
 * tests/patrol/test_sweeps.py).
 *
 * Bounds: the geometry (sizes, plane table, station positions, index weights) is checked
 * exactly against its definition (lpbounds.patrol.sweeps.geometry) at every call, so every
 * index the walk forms is a state (the model maps states to states; the tests check it
 * at every state); the arrays' lengths, the policy's actions and the labels' partitions
 * are checked. A bad argument is a TypeError or ValueError naming it, never a wild read.
 */
#include "patrol.h"

/* geo fields (GEO_FIELDS) */
enum { G_N, G_M, G_D, G_G, G_R, G_T, G_TBS, G_LBS, G_NS, G_LEN };
/* plane fields (PLANE_FIELDS) */
enum { P_L, P_W, P_D, P_K, P_LAST, P_LOITER, P_B0, P_B1, P_B2, P_X0, P_LEN };
/* loiter rules */
enum { NEVER, ALWAYS, FROM_ONE, BY_DELAY };

typedef struct {
    PModel pm;
    int64_t n_planes;
    const int64_t *planes; /* (n_planes, P_LEN) */
    const int64_t *weights; /* (m + 1, m): loiter rows k, the travel row m */
} Geo;

#define PL(p, f) (g->planes[(p) * P_LEN + (f)])
#define WT(row, j) (g->weights[(row) * g->pm.m + (j)])

/* The plane table's row ``p`` as lpbounds.patrol.sweeps._plane_row makes it; ``rule``
 * the loiter rule of a travel plane at a station with d = 0, which depends on
 * allow_empty_loiter (ALWAYS if allowed): the caller accepts either. */
static void plane_row(const Geo *g, int64_t p, int64_t *row, int empty_allowed) {
    const PModel *pm = &g->pm;
    int64_t l, w, d, k, last, x0;
    if (p < 2 * pm->N) {
        l = p / 2;
        w = 1 - 2 * (p % 2);
        d = 0;
        k = pm->station_pos[l];
        last = pm->m - 1;
        x0 = p * pm->rm;
    } else {
        k = (p - 2 * pm->N) / pm->D;
        d = (p - 2 * pm->N) % pm->D + 1;
        l = pm->stations[k];
        w = 1;
        last = k != pm->m - 1 ? pm->m - 1 : pm->m - 2;
        x0 = pm->n_travel + (k * pm->D + d - 1) * pm->rm1;
    }
    int64_t rule;
    if (k < 0 || d >= pm->D)
        rule = NEVER;
    else if (d >= 1 || empty_allowed)
        rule = ALWAYS;
    else
        rule = k == last ? FROM_ONE : BY_DELAY;
    row[P_L] = l;
    row[P_W] = w;
    row[P_D] = d;
    row[P_K] = k;
    row[P_LAST] = last;
    row[P_LOITER] = rule;
    for (int a = 0; a < 2; a++) {
        int64_t w2 = w * (a == 0 ? 1 : -1);
        int64_t l2 = floor_mod(l + w2, pm->N);
        row[P_B0 + a] = (2 * l2 + (w2 < 0 ? 1 : 0)) * pm->rm;
    }
    row[P_B2] = rule != NEVER ? pm->n_travel + (k * pm->D + d) * pm->rm1 : 0;
    row[P_X0] = x0;
}

static const char *const PLANE_NAMES[P_LEN] = {"l", "w", "d", "k", "last", "loiter",
                                               "b0", "b1", "b2", "x0"};

/* The geometry's buffers b[0..3] (geo, planes, sp, weights), checked exactly. */
static int load_geo(PyObject *o_geo, PyObject *o_planes, PyObject *o_sp, PyObject *o_w,
                    Buf *b, Geo *g) {
    if (get(o_geo, &b[0], "geo", 1, 'i', 8, 0, 0) ||
        get(o_planes, &b[1], "planes", 2, 'i', 8, 0, 0) ||
        get(o_sp, &b[2], "sp", 1, 'i', 8, 0, 0) ||
        get(o_w, &b[3], "weights", 2, 'i', 8, 0, 0) || check_shape(&b[0], "geo", G_LEN, -1))
        return -1;
    const int64_t *geo = b[0].b.buf;
    PModel *pm = &g->pm;
    if (pmodel_sizes(pm, geo[G_N], geo[G_M], geo[G_D], geo[G_G]))
        return -1;
    const int64_t want[G_LEN] = {pm->N,       pm->m,       pm->D,       pm->gamma,   pm->radix,
                                 pm->n_travel, pm->tb_size, pm->lb_size, pm->n_states};
    for (int f = 0; f < G_LEN; f++)
        if (geo[f] != want[f]) {
            PyErr_Format(PyExc_ValueError, "geo[%d] = %lld, expected %lld (from N, m, D, Gamma)",
                         f, (long long)geo[f], (long long)want[f]);
            return -1;
        }
    g->n_planes = 2 * pm->N + pm->m * pm->D;
    if (check_shape(&b[2], "sp", pm->N, -1) || check_shape(&b[1], "planes", g->n_planes, P_LEN) ||
        check_shape(&b[3], "weights", pm->m + 1, pm->m))
        return -1;
    /* the stations from sp: stations[k] is the node of position k */
    const int64_t *sp = b[2].b.buf;
    int64_t stations[PATROL_MMAX];
    for (int64_t k = 0; k < pm->m; k++)
        stations[k] = -1;
    for (int64_t l = 0; l < pm->N; l++)
        if (sp[l] >= 0 && sp[l] < pm->m)
            stations[sp[l]] = l;
    if (pmodel_stations(pm, sp, stations))
        return -1;
    g->planes = b[1].b.buf;
    g->weights = b[3].b.buf;
    const int64_t *wt = g->weights + pm->m * pm->m;
    if (pmodel_weights(pm, wt, g->weights, pm->m, "weights[m]", "weights"))
        return -1;
    for (int64_t p = 0; p < g->n_planes; p++) {
        int64_t row[P_LEN], alt[P_LEN];
        plane_row(g, p, row, 0);
        plane_row(g, p, alt, 1);
        for (int f = 0; f < P_LEN; f++) {
            int64_t got = PL(p, f);
            if (got != row[f] && got != alt[f]) {
                PyErr_Format(PyExc_ValueError,
                             "planes[%lld, %d] (%s) = %lld, expected %lld (the geometry of geo)",
                             (long long)p, f, PLANE_NAMES[f], (long long)got,
                             (long long)row[f]);
                return -1;
            }
        }
        /* one rule or the other for the whole row (the base b2 follows the rule) */
        int is_row = 1, is_alt = 1;
        for (int f = 0; f < P_LEN; f++) {
            is_row = is_row && PL(p, f) == row[f];
            is_alt = is_alt && PL(p, f) == alt[f];
        }
        if (!is_row && !is_alt) {
            PyErr_Format(PyExc_ValueError, "planes[%lld]: the loiter rule and b2 disagree",
                         (long long)p);
            return -1;
        }
    }
    pm->stations = NULL; /* the local copy goes out of scope; the walk needs sp only */
    return 0;
}

/* probs (m + 1,), inc (D + 1,), pent (Gamma + 1,) into b[0..2] */
static int load_floats(PyObject *o_p, PyObject *o_inc, PyObject *o_pent, Buf *b, const Geo *g) {
    if (get(o_p, &b[0], "probs", 1, 'f', 0, 0, 0) ||
        get(o_inc, &b[1], "inc", 1, 'f', 0, 0, 0) ||
        get(o_pent, &b[2], "pent", 1, 'f', 0, 0, 0) ||
        check_shape(&b[0], "probs", g->pm.m + 1, -1) ||
        check_shape(&b[1], "inc", g->pm.D + 1, -1) ||
        check_shape(&b[2], "pent", g->pm.radix, -1))
        return -1;
    return 0;
}

/* ------------------------------------------------------------------ the walk */
/* A range's cursor and row buffers (one per thread). */
typedef struct {
    int64_t tau[PATROL_MMAX];
    int64_t rr[3][2][PATROL_MMAX + 1];
    int64_t gl[3];
    double *acc; /* 3 rows of Gamma + 1 */
} Walk;

/* what row_setup reports */
typedef struct {
    int64_t last, t0, length, pmax, loiter, acode;
} Row;

Py_LOCAL_INLINE(int64_t) next_delay(int64_t t, int64_t gamma) {
    return t == 0 ? 0 : (gamma < t + 1 ? gamma : t + 1);
}

Py_LOCAL_INLINE(int) loiter_at(int64_t loiter, int64_t t) {
    return loiter == ALWAYS || (loiter == FROM_ONE && t >= 1);
}

/* The plane of state x; its delays into tau (0 at the own station of a loiter state). */
static int64_t cursor_at(const Geo *g, int64_t x, int64_t *tau) {
    int64_t plane;
    if (x < g->pm.n_travel)
        plane = x / g->pm.rm;
    else
        plane = 2 * g->pm.N + (x - g->pm.n_travel) / g->pm.rm1;
    int64_t code = x - PL(plane, P_X0);
    int64_t own = PL(plane, P_D) > 0 ? PL(plane, P_K) : -1;
    for (int64_t j = g->pm.m - 1; j >= 0; j--) {
        if (j == own) {
            tau[j] = 0;
        } else {
            tau[j] = code % g->pm.radix;
            code /= g->pm.radix;
        }
    }
    return plane;
}

/* The next row after a finished one (the counter plus one); the plane. */
Py_LOCAL_INLINE(int64_t) advance(const Geo *g, int64_t plane, int64_t *tau) {
    int64_t last = PL(plane, P_LAST);
    if (last < 0)
        return plane + 1;
    int64_t own = PL(plane, P_D) > 0 ? PL(plane, P_K) : -1;
    tau[last] = 0;
    for (int64_t j = last - 1; j >= 0; j--) {
        if (j == own)
            continue;
        tau[j] += 1;
        if (tau[j] < g->pm.radix)
            return plane;
        tau[j] = 0;
    }
    return plane + 1;
}

/* The successors of the row at the cursor into rr and gl (sweeps.row_setup). */
Py_LOCAL_INLINE(Row) row_setup(const Geo *g, int64_t plane, Walk *wk) {
    int64_t m = g->pm.m, gamma = g->pm.gamma;
    const int64_t *tau = wk->tau;
    Row rw;
    int64_t last = PL(plane, P_LAST), k = PL(plane, P_K), loiter = PL(plane, P_LOITER);
    if (loiter == BY_DELAY)
        loiter = tau[k] > 0 ? ALWAYS : NEVER;
    int64_t pmax = 0, acode = 0;
    for (int64_t j = 0; j < m; j++)
        if (j != last) {
            if (tau[j] > pmax)
                pmax = tau[j];
            if (tau[j] > 0)
                acode |= (int64_t)1 << (m - 1 - j);
        }
    for (int a = 0; a < 3; a++) {
        if (a == 2 && loiter == NEVER) {
            wk->gl[a] = 0;
            continue;
        }
        int64_t wrow = a == 2 ? k : m;
        int64_t rb = PL(plane, P_B0 + a);
        for (int64_t j = 0; j < m; j++)
            if (j != last)
                rb += next_delay(tau[j], gamma) * WT(wrow, j);
        int64_t gg = last >= 0 ? WT(wrow, last) : 0;
        wk->gl[a] = gg;
        wk->rr[a][0][0] = rb;
        wk->rr[a][1][0] = rb;
        for (int64_t j = 0; j < m; j++) {
            if (j == last) {
                wk->rr[a][0][j + 1] = rb + gg;
                wk->rr[a][1][j + 1] = rb;
            } else {
                int64_t off = tau[j] == 0 ? WT(wrow, j) : 0;
                wk->rr[a][0][j + 1] = rb + off;
                wk->rr[a][1][j + 1] = rb + off;
            }
        }
    }
    rw.last = last;
    rw.pmax = pmax;
    rw.loiter = loiter;
    rw.acode = acode;
    if (last < 0) {
        rw.t0 = 0;
        rw.length = 1;
    } else {
        rw.t0 = tau[last];
        rw.length = g->pm.radix - rw.t0;
    }
    return rw;
}

/* The successor of outcome o under action a at the row's fast digit t. */
Py_LOCAL_INLINE(int64_t) succ_index(const Walk *wk, int a, int64_t o, int64_t t, int64_t gamma) {
    if (t == 0)
        return wk->rr[a][0][o];
    return wk->rr[a][1][o] + next_delay(t, gamma) * wk->gl[a];
}

/* sum_o probs[o] v[rr[a, side, o] + shift] from 0.0 in outcome order */
Py_LOCAL_INLINE(double) sum_at(const double *v, const double *probs, int64_t n_out,
                               const Walk *wk, int a, int side, int64_t shift) {
    double s = 0.0;
    for (int64_t o = 0; o < n_out; o++)
        s += probs[o] * v[wk->rr[a][side][o] + shift];
    return s;
}

/* row[t] = sum_o probs[o] v[succ(a, o, t)] for the nb states of a whole row, each from 0.0
 * in outcome order (sweeps._accumulate: the same cases, the same terms). */
static void accumulate(const double *v, const double *probs, int64_t n_out, const Walk *wk,
                       int a, int64_t nb, int64_t gamma, double *row) {
    row[0] = sum_at(v, probs, n_out, wk, a, 0, 0);
    if (nb == 1)
        return;
    int64_t gg = wk->gl[a];
    if (gg == 0) {
        double s = sum_at(v, probs, n_out, wk, a, 1, 0);
        for (int64_t t = 1; t < nb; t++)
            row[t] = s;
        return;
    }
    if (gamma == 1) { /* the row is t = 0, 1 and f(1) = 1 */
        row[1] = sum_at(v, probs, n_out, wk, a, 1, gg);
        return;
    }
    if (gg == 1) { /* consecutive indices: four states at a time, their sums in registers */
        int64_t t = 1;
        while (t + 4 <= gamma) {
            double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
            for (int64_t o = 0; o < n_out; o++) {
                double po = probs[o];
                const double *b = v + (wk->rr[a][1][o] + t + 1);
                s0 += po * b[0];
                s1 += po * b[1];
                s2 += po * b[2];
                s3 += po * b[3];
            }
            row[t] = s0;
            row[t + 1] = s1;
            row[t + 2] = s2;
            row[t + 3] = s3;
            t += 4;
        }
        while (t < gamma) {
            double s = 0.0;
            for (int64_t o = 0; o < n_out; o++)
                s += probs[o] * v[wk->rr[a][1][o] + t + 1];
            row[t] = s;
            t += 1;
        }
    } else { /* slot j is t = j + 1: index rr + (j + 2) g */
        double *seg = row + 1;
        int64_t cnt = gamma - 1;
        for (int64_t j = 0; j < cnt; j++)
            seg[j] = 0.0;
        for (int64_t o = 0; o < n_out; o++) {
            double po = probs[o];
            const double *b = v + (wk->rr[a][1][o] + 2 * gg);
            for (int64_t j = 0; j < cnt; j++)
                seg[j] += po * b[gg * j];
        }
    }
    row[gamma] = row[gamma - 1]; /* f(Gamma) = f(Gamma - 1) = Gamma */
}

/* the row's sums of the actions whose bit 1 << a is set in used */
Py_LOCAL_INLINE(void) row_sums(const double *v, const double *probs, int64_t n_out,
                               const Walk *wk, int64_t nb, int64_t gamma, int used) {
    for (int a = 0; a < 3; a++)
        if (used & (1 << a))
            accumulate(v, probs, n_out, wk, a, nb, gamma, wk->acc + a * (gamma + 1));
}

/* States [start, end) of chunk c of n: consecutive, starting at a row boundary. */
Py_LOCAL_INLINE(void) chunk_of(int64_t n, int64_t nchunks, int64_t radix, int64_t c,
                               int64_t *start, int64_t *end) {
    int64_t size = (n + nchunks - 1) / nchunks;
    size = (size + radix - 1) / radix * radix;
    int64_t s = c * size, e = (c + 1) * size;
    *start = s < n ? s : n;
    *end = e < n ? e : n;
}

/* Units [start, end) of chunk c (a travel unit is the pair of a node's two planes' states
 * with the same delays, x and x + R^m; a loiter unit one state) and the state of unit
 * start (sweeps._unit_chunk). */
Py_LOCAL_INLINE(void) unit_chunk(const Geo *g, int64_t nchunks, int64_t c, int64_t *u,
                                 int64_t *end, int64_t *x, int64_t *rm) {
    int64_t half = g->pm.n_travel / 2;
    chunk_of(g->pm.n_states - half, nchunks, g->pm.radix, c, u, end);
    *rm = half / g->pm.N;
    *x = *u < half ? *u + (*u / *rm) * *rm : *u + half;
}

/* the next unit row: past a pair's (l, +1) plane, the next node's, skipping (l, -1) */
Py_LOCAL_INLINE(int64_t) next_row(const Geo *g, int64_t plane, Walk *wk, int64_t *x,
                                  int64_t rm) {
    plane = advance(g, plane, wk->tau);
    if (plane < 2 * g->pm.N && plane % 2 == 1) {
        *x += rm;
        return plane + 1;
    }
    return plane;
}

/* A range's buffers; NULL with MemoryError set. */
static int walk_alloc(Walk *wk, const Geo *g) {
    memset(wk->tau, 0, sizeof wk->tau);
    wk->acc = (double *)malloc(sizeof(double) * 3 * (size_t)g->pm.radix);
    if (!wk->acc) {
        PyErr_NoMemory();
        return -1;
    }
    return 0;
}

/* the partition of the row's state at fast digit t (sweeps._label) */
Py_LOCAL_INLINE(int64_t) label_of(const Geo *g, int64_t plane, const Row *rw, int64_t t) {
    int64_t acode = rw->acode;
    if (rw->last >= 0 && t > 0)
        acode |= (int64_t)1 << (g->pm.m - 1 - rw->last);
    int64_t tb = t > rw->pmax ? t : rw->pmax;
    return key_index(PL(plane, P_L), PL(plane, P_W), PL(plane, P_D), acode, tb,
                     g->pm.station_pos, g->pm.N, g->pm.D, g->pm.gamma, g->pm.tb_size,
                     g->pm.lb_size, g->pm.m);
}

/* the range [c0, c1) of nchunks chunks */
static int chunks_ok(Py_ssize_t nchunks, Py_ssize_t c0, Py_ssize_t c1) {
    if (nchunks < 1) {
        PyErr_Format(PyExc_ValueError, "nchunks must be >= 1; got %zd", nchunks);
        return -1;
    }
    return check_range(c0, c1, nchunks);
}

/* numba's min and max: the first of the extremes, by strict comparison */
#define FOLD_MIN(acc, x) ((x) < (acc) ? (x) : (acc))
#define FOLD_MAX(acc, x) ((x) > (acc) ? (x) : (acc))

/* ------------------------------------------------------------------ opening a call */
/* The geometry into b[0..3], the chunk range and the walk's buffers: 0, or -1 with the
 * exception set. */
static int open_walk(PyObject *const *o_geo, Buf *b, Geo *g, Walk *wk, Py_ssize_t nchunks,
                     Py_ssize_t c0, Py_ssize_t c1) {
    wk->acc = NULL;
    if (load_geo(o_geo[0], o_geo[1], o_geo[2], o_geo[3], b, g) || chunks_ok(nchunks, c0, c1))
        return -1;
    return walk_alloc(wk, g);
}

/* The end of a call: the walk's buffers and the arrays released; ``res`` or NULL. */
static PyObject *close_walk(PyObject *res, Walk *wk, Buf *b, int nb) {
    free(wk->acc);
    release(b, nb);
    return res;
}

#define MIN64(a, b) ((a) < (b) ? (a) : (b))

/* ------------------------------------------------------------------ the sweeps */
/* The max over the actions of the row of states x.. whose "continue" sums are qa and
 * "reverse" sums qb (sweeps._max_row). */
Py_LOCAL_INLINE(void) max_row(int64_t x, int64_t nb, const Row *rw, double inc_d,
                              const double *pent, double lam, const double *qa,
                              const double *qb, const double *ql, const double *v, double *out,
                              int8_t *arg, double *lc, double *hc) {
    for (int64_t t = 0; t < nb; t++) {
        double pen = pent[t > rw->pmax ? t : rw->pmax];
        double best = pen + lam * qa[t];
        int8_t best_a = 0;
        double q = pen + lam * qb[t];
        if (q > best) {
            best = q;
            best_a = 1;
        }
        if (loiter_at(rw->loiter, t)) {
            q = (pen + inc_d) + lam * ql[t];
            if (q > best) {
                best = q;
                best_a = 2;
            }
        }
        out[x + t] = best;
        arg[x + t] = best_a;
        double diff = best - v[x + t];
        *lc = FOLD_MIN(*lc, diff);
        *hc = FOLD_MAX(*hc, diff);
    }
}

/* T_pi v on the row of states x.. (twin: an (l, -1) plane, whose moves swap the sums). */
Py_LOCAL_INLINE(void) policy_row(int64_t x, int64_t nb, const Row *rw, double inc_d,
                                 const double *pent, double lam, const int8_t *act,
                                 const double *acc, int64_t R, int twin, const double *v,
                                 double *out, double *lc, double *hc) {
    for (int64_t t = 0; t < nb; t++) {
        int64_t a = act[x + t];
        double r = pent[t > rw->pmax ? t : rw->pmax];
        if (a == 2)
            r = r + inc_d;
        double q = r + lam * acc[(twin && a < 2 ? 1 - a : a) * R + t];
        out[x + t] = q;
        double diff = q - v[x + t];
        *lc = FOLD_MIN(*lc, diff);
        *hc = FOLD_MAX(*hc, diff);
    }
}

/* Bit a set if a state x.. of the row takes the action whose sum is acc[a] (twin: the
 * states of an (l, -1) plane, whose moves swap the sums); -1 - i for the first state
 * x + i whose action is not 0, 1 or an allowed loiter. */
Py_LOCAL_INLINE(int64_t) used_actions(const int8_t *act, int64_t x, int64_t nb, int twin,
                                      int64_t loiter) {
    int64_t used = 0;
    for (int64_t i = 0; i < nb; i++) {
        int64_t a = act[x + i];
        if (a < 0 || a > 2 || (a == 2 && !loiter_at(loiter, i)))
            return -1 - i;
        used |= (int64_t)1 << (twin && a < 2 ? 1 - a : a);
    }
    return used;
}

/* The sweeps walk units (sweeps.py: a travel unit is the pair of a node's two planes'
 * states with the same delays, whose row of sums serves both). ``act`` NULL: the max sweep
 * (out, arg); else the policy sweep. Returns the first state whose action is not allowed,
 * or -1. The extremes fold every state's out - v in index order (strict <, >, from +inf,
 * -inf: the first of the extremes, NaN skipped), which is what numba's per-chunk min and
 * max, then the chunks' in order, gave. */
static int64_t sweep_units(const Geo *g, Walk *wk, const double *probs, const double *inc,
                           const double *pent, double lam, const int8_t *act, const double *v,
                           double *out, int8_t *arg, int64_t nchunks, int64_t c0, int64_t c1,
                           double *lo, double *hi) {
    int64_t n_out = g->pm.m + 1, gamma = g->pm.gamma, R = g->pm.radix;
    const double *q0 = wk->acc, *q1 = wk->acc + R, *q2 = wk->acc + 2 * R;
    for (int64_t c = c0; c < c1; c++) {
        int64_t u, end, x, rm;
        unit_chunk(g, nchunks, c, &u, &end, &x, &rm);
        int64_t plane = u < end ? cursor_at(g, x, wk->tau) : 0;
        while (u < end) { /* whole rows: chunks start at row boundaries */
            Row rw = row_setup(g, plane, wk);
            int64_t nb = rw.length;
            double inc_d = inc[PL(plane, P_D)];
            int pair = plane < 2 * g->pm.N;
            if (act) {
                int64_t used = used_actions(act, x, nb, 0, rw.loiter);
                int64_t used2 = pair ? used_actions(act, x + rm, nb, 1, rw.loiter) : 0;
                if (used < 0 || used2 < 0)
                    return used < 0 ? x - 1 - used : x + rm - 1 - used2;
                row_sums(v, probs, n_out, wk, nb, gamma, (int)(used | used2));
                policy_row(x, nb, &rw, inc_d, pent, lam, act, wk->acc, R, 0, v, out, lo, hi);
                if (pair)
                    policy_row(x + rm, nb, &rw, inc_d, pent, lam, act, wk->acc, R, 1, v, out, lo,
                               hi);
            } else {
                row_sums(v, probs, n_out, wk, nb, gamma, rw.loiter == NEVER ? 3 : 7);
                max_row(x, nb, &rw, inc_d, pent, lam, q0, q1, q2, v, out, arg, lo, hi);
                if (pair) /* the (l, -1) twin: its moves swap the two sums */
                    max_row(x + rm, nb, &rw, inc_d, pent, lam, q1, q0, q2, v, out, arg, lo, hi);
            }
            u += nb;
            x += nb;
            if (u < end)
                plane = next_row(g, plane, wk, &x, rm);
        }
    }
    return -1;
}

/* max_sweep and policy_sweep: (geo, planes, sp, weights, probs, inc, pent, discount,
 * A, B, C, nchunks, c0, c1), A B C = v, out, arg or act, v, out. */
static PyObject *sweep(PyObject *args, int policy) {
    PyObject *o[10];
    double lam;
    Py_ssize_t nchunks, c0, c1;
    if (!PyArg_ParseTuple(args, "OOOOOOOdOOOnnn", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5],
                          &o[6], &lam, &o[7], &o[8], &o[9], &nchunks, &c0, &c1))
        return NULL;
    Buf b[10];
    memset(b, 0, sizeof b);
    Geo geo;
    const Geo *g = &geo;
    Walk wk;
    Buf *v = &b[policy ? 8 : 7], *out = &b[policy ? 9 : 8], *a = &b[policy ? 7 : 9];
    if (open_walk(o, b, &geo, &wk, nchunks, c0, c1) || load_floats(o[4], o[5], o[6], b + 4, g) ||
        get(o[policy ? 8 : 7], v, "v", 1, 'f', 0, 0, 0) ||
        get(o[policy ? 9 : 8], out, "out", 1, 'f', 0, 1, 0) ||
        get(o[policy ? 7 : 9], a, policy ? "act" : "arg", 1, 'i', 1, !policy, 0) ||
        check_shape(v, "v", g->pm.n_states, -1) || check_shape(out, "out", g->pm.n_states, -1) ||
        check_shape(a, policy ? "act" : "arg", g->pm.n_states, -1))
        return close_walk(NULL, &wk, b, 10);
    double lo = INFINITY, hi = -INFINITY;
    int8_t *acts = a->b.buf;
    int64_t bad;
    Py_BEGIN_ALLOW_THREADS
    bad = sweep_units(g, &wk, b[4].b.buf, b[5].b.buf, b[6].b.buf, lam, policy ? acts : NULL,
                      v->b.buf, out->b.buf, acts, nchunks, c0, c1, &lo, &hi);
    Py_END_ALLOW_THREADS
    if (bad >= 0) {
        PyErr_Format(PyExc_ValueError, "act[%lld] = %d is not an allowed action of state %lld",
                     (long long)bad, (int)acts[bad], (long long)bad);
        return close_walk(NULL, &wk, b, 10);
    }
    return close_walk(Py_BuildValue("dd", lo, hi), &wk, b, 10);
}

PyDoc_STRVAR(max_sweep_doc,
             "max_sweep(geo, planes, sp, weights, probs, inc, pent, discount, v, out, arg, "
             "nchunks, c0, c1) -> (lo, hi)\n\n"
             "out = T v on the chunks c0 <= c < c1 (the first maximising action in arg, int8);"
             " returns the min and max of out - v over them. Releases the GIL.");

static PyObject *max_sweep(PyObject *Py_UNUSED(self), PyObject *args) { return sweep(args, 0); }

PyDoc_STRVAR(policy_sweep_doc,
             "policy_sweep(geo, planes, sp, weights, probs, inc, pent, discount, act, v, out, "
             "nchunks, c0, c1) -> (lo, hi)\n\n"
             "out = T_pi v for the actions act (int8) on the chunks c0 <= c < c1; returns the "
             "min and max of out - v over them. A ValueError names the first state whose "
             "action is not allowed. Releases the GIL.");

static PyObject *policy_sweep(PyObject *Py_UNUSED(self), PyObject *args) { return sweep(args, 1); }

/* ------------------------------------------------------------------ passes */
/* What a pass does with one row: the states x .. x + nb - 1 (fast digits rw->t0 ..) of
 * chunk c; nonzero stops the walk. */
typedef int (*RowFn)(void *ctx, const Geo *g, Walk *wk, int64_t c, int64_t plane,
                     const Row *rw, int64_t x, int64_t nb);

/* The rows of the chunks c0 <= c < c1 of n states (chunks of whole ``unit``s of states;
 * the states are start0 + x), in index order (sweeps._walk_start and its loops). */
static void walk_rows(const Geo *g, Walk *wk, int64_t n, int64_t unit, int64_t start0,
                      int64_t nchunks, int64_t c0, int64_t c1, RowFn fn, void *ctx) {
    for (int64_t c = c0; c < c1; c++) {
        int64_t x, end;
        chunk_of(n, nchunks, unit, c, &x, &end);
        int64_t plane = x < end ? cursor_at(g, start0 + x, wk->tau) : 0;
        while (x < end) {
            Row rw = row_setup(g, plane, wk);
            int64_t nb = MIN64(rw.length, end - x);
            if (fn(ctx, g, wk, c, plane, &rw, x, nb))
                return;
            x += nb;
            if (x < end)
                plane = advance(g, plane, wk->tau);
        }
    }
}

/* at most the model's states (a ValueError naming the array) */
static int at_most_states(const Buf *b, const char *name, const Geo *g) {
    if (b->b.shape[0] > g->pm.n_states) {
        PyErr_Format(PyExc_ValueError, "%s: length %zd, more than the %lld states", name,
                     b->b.shape[0], (long long)g->pm.n_states);
        return -1;
    }
    return 0;
}

typedef struct {
    char *out; /* labels (int32 or int64), comps (int64, n x (3 + m)) or successors */
    int wide;
    int64_t action;
    const int8_t *act;
    int64_t first;
    const double *inc, *pent;
    double best;
} PassCtx;

static int labels_row(void *ctx, const Geo *g, Walk *Py_UNUSED(wk), int64_t Py_UNUSED(c),
                      int64_t plane, const Row *rw, int64_t x, int64_t nb) {
    PassCtx *p = ctx;
    for (int64_t i = 0; i < nb; i++) {
        int64_t k = label_of(g, plane, rw, rw->t0 + i);
        if (p->wide)
            ((int64_t *)p->out)[x + i] = k;
        else
            ((int32_t *)p->out)[x + i] = (int32_t)k;
    }
    return 0;
}

static int decode_row(void *ctx, const Geo *g, Walk *wk, int64_t Py_UNUSED(c), int64_t plane,
                      const Row *rw, int64_t x, int64_t nb) {
    PassCtx *p = ctx;
    int64_t m = g->pm.m;
    for (int64_t i = 0; i < nb; i++) {
        int64_t *row = (int64_t *)p->out + (x + i) * (3 + m);
        row[0] = PL(plane, P_L);
        row[1] = PL(plane, P_W);
        row[2] = PL(plane, P_D);
        for (int64_t j = 0; j < m; j++)
            row[3 + j] = wk->tau[j];
        if (rw->last >= 0)
            row[3 + rw->last] = rw->t0 + i;
    }
    return 0;
}

static int successor_row(void *ctx, const Geo *g, Walk *wk, int64_t Py_UNUSED(c),
                         int64_t Py_UNUSED(plane), const Row *rw, int64_t x, int64_t nb) {
    PassCtx *p = ctx;
    int64_t width = g->pm.m + 1, *out = (int64_t *)p->out;
    int a = (int)p->action;
    for (int64_t i = 0; i < nb; i++) {
        int ok = a < 2 || loiter_at(rw->loiter, rw->t0 + i);
        for (int64_t o = 0; o < width; o++)
            out[(x + i) * width + o] = ok ? succ_index(wk, a, o, rw->t0 + i, g->pm.gamma) : -1;
    }
    return 0;
}

static int check_row(void *ctx, const Geo *Py_UNUSED(g), Walk *Py_UNUSED(wk), int64_t Py_UNUSED(c),
                     int64_t Py_UNUSED(plane), const Row *rw, int64_t x, int64_t nb) {
    PassCtx *p = ctx;
    for (int64_t i = 0; i < nb; i++)
        if (p->act[x + i] == 2 && !loiter_at(rw->loiter, rw->t0 + i)) {
            p->first = x + i;
            return 1;
        }
    return 0;
}

/* The passes over one integer array: its name, dimensions, item sizes, whether written,
 * whether the call has a scalar before it (start0, action), what a row does. */
typedef struct {
    const char *name;
    int ndim, sizes, writable, scalar;
    RowFn fn;
} ArrayPass;

enum { LABELS, DECODE, SUCCESSORS, CHECK };
static const ArrayPass ARRAY_PASSES[4] = {
    {"labels", 1, S_IDX, 1, 0, labels_row},
    {"comps", 2, 8, 1, 1, decode_row},
    {"out", 2, 8, 1, 1, successor_row},
    {"act", 1, 1, 0, 0, check_row},
};

/* labels_pass, decode_range, successor_range, check_policy_pass: (geo, planes, sp, weights,
 * [start0 | action,] array, nchunks, c0, c1) */
static PyObject *array_pass(PyObject *args, int which) {
    const ArrayPass *ps = &ARRAY_PASSES[which];
    PyObject *o[5];
    long long scalar = 0;
    Py_ssize_t nchunks, c0, c1;
    if (!(ps->scalar ? PyArg_ParseTuple(args, "OOOOLOnnn", &o[0], &o[1], &o[2], &o[3], &scalar,
                                        &o[4], &nchunks, &c0, &c1)
                     : PyArg_ParseTuple(args, "OOOOOnnn", &o[0], &o[1], &o[2], &o[3], &o[4],
                                        &nchunks, &c0, &c1)))
        return NULL;
    Buf b[5];
    memset(b, 0, sizeof b);
    Geo g;
    Walk wk;
    if (open_walk(o, b, &g, &wk, nchunks, c0, c1) ||
        get(o[4], &b[4], ps->name, ps->ndim, 'i', ps->sizes, ps->writable, 0))
        return close_walk(NULL, &wk, b, 5);
    int64_t n = b[4].b.shape[0], m = g.pm.m;
    int bad = (which == DECODE && check_shape(&b[4], "comps", -1, 3 + m)) ||
              (which == SUCCESSORS && check_shape(&b[4], "out", -1, m + 1)) ||
              (which != DECODE && at_most_states(&b[4], ps->name, &g));
    if (!bad && which == DECODE && (scalar < 0 || scalar > g.pm.n_states - n)) {
        PyErr_Format(PyExc_ValueError, "start0 = %lld: states start0 .. start0 + %lld are "
                     "not all among the %lld states", scalar, (long long)n,
                     (long long)g.pm.n_states);
        bad = 1;
    }
    if (!bad && which == SUCCESSORS && (scalar < 0 || scalar > 2)) {
        PyErr_Format(PyExc_ValueError, "action = %lld: expected 0, 1 or 2", scalar);
        bad = 1;
    }
    if (bad)
        return close_walk(NULL, &wk, b, 5);
    PassCtx p = {b[4].b.buf, b[4].b.itemsize == 8, scalar, b[4].b.buf, -1, NULL, NULL, 0.0};
    int64_t unit = which == DECODE ? 1 : g.pm.radix, start0 = which == DECODE ? scalar : 0;
    Py_BEGIN_ALLOW_THREADS
    walk_rows(&g, &wk, n, unit, start0, nchunks, c0, c1, ps->fn, &p);
    Py_END_ALLOW_THREADS
    return close_walk(which == CHECK ? PyLong_FromLongLong(p.first) : Py_NewRef(Py_None), &wk, b,
                      5);
}

PyDoc_STRVAR(labels_pass_doc,
             "labels_pass(geo, planes, sp, weights, labels, nchunks, c0, c1)\n\n"
             "labels[x] (int32 or int64): the partition of every state x < labels.size of "
             "the chunks c0 <= c < c1. Releases the GIL.");

static PyObject *labels_pass(PyObject *Py_UNUSED(self), PyObject *args) {
    return array_pass(args, LABELS);
}

PyDoc_STRVAR(decode_range_doc,
             "decode_range(geo, planes, sp, weights, start0, comps, nchunks, c0, c1)\n\n"
             "comps[i] = (l, w, d, tau_1..tau_m) of state start0 + i as the walk sees it, for "
             "the chunks c0 <= c < c1 of the rows of comps (int64, (n, 3 + m)). Releases the "
             "GIL.");

static PyObject *decode_range(PyObject *Py_UNUSED(self), PyObject *args) {
    return array_pass(args, DECODE);
}

PyDoc_STRVAR(successor_range_doc,
             "successor_range(geo, planes, sp, weights, action, out, nchunks, c0, c1)\n\n"
             "The walk's successors of every state x < out.shape[0] under action into out "
             "(int64, (n, m + 1)), -1 where the action is not allowed, for the chunks "
             "c0 <= c < c1. Releases the GIL.");

static PyObject *successor_range(PyObject *Py_UNUSED(self), PyObject *args) {
    return array_pass(args, SUCCESSORS);
}

PyDoc_STRVAR(check_policy_pass_doc,
             "check_policy_pass(geo, planes, sp, weights, act, nchunks, c0, c1) -> int\n\n"
             "The first state x < act.size of the chunks c0 <= c < c1 whose action act[x] "
             "(int8) is a forbidden loiter, or -1. Releases the GIL.");

static PyObject *check_policy_pass(PyObject *Py_UNUSED(self), PyObject *args) {
    return array_pass(args, CHECK);
}

/* the fold of |R_u(x)| over the row: every value >= +0.0, so folding the chunks into one
 * maximum from 0.0 is numba's per-chunk maxima from 0.0, then their maximum */
static int absmax_row(void *ctx, const Geo *g, Walk *Py_UNUSED(wk), int64_t Py_UNUSED(c),
                      int64_t plane, const Row *rw, int64_t Py_UNUSED(x), int64_t nb) {
    PassCtx *p = ctx;
    double inc_d = p->inc[PL(plane, P_D)];
    for (int64_t i = 0; i < nb; i++) {
        int64_t t = rw->t0 + i;
        double pen = p->pent[t > rw->pmax ? t : rw->pmax];
        p->best = FOLD_MAX(p->best, fabs(pen));
        if (loiter_at(rw->loiter, t))
            p->best = FOLD_MAX(p->best, fabs(pen + inc_d));
    }
    return 0;
}

PyDoc_STRVAR(reward_absmax_pass_doc,
             "reward_absmax_pass(geo, planes, sp, weights, inc, pent, nchunks, c0, c1) -> "
             "float\n\nmax |R_u(x)| over the allowed pairs of the chunks c0 <= c < c1. "
             "Releases the GIL.");

static PyObject *reward_absmax_pass(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o[6];
    Py_ssize_t nchunks, c0, c1;
    if (!PyArg_ParseTuple(args, "OOOOOOnnn", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5],
                          &nchunks, &c0, &c1))
        return NULL;
    Buf b[6];
    memset(b, 0, sizeof b);
    Geo g;
    Walk wk;
    if (open_walk(o, b, &g, &wk, nchunks, c0, c1) ||
        get(o[4], &b[4], "inc", 1, 'f', 0, 0, 0) ||
        get(o[5], &b[5], "pent", 1, 'f', 0, 0, 0) ||
        check_shape(&b[4], "inc", g.pm.D + 1, -1) || check_shape(&b[5], "pent", g.pm.radix, -1))
        return close_walk(NULL, &wk, b, 6);
    PassCtx p = {NULL, 0, 0, NULL, -1, b[4].b.buf, b[5].b.buf, 0.0};
    Py_BEGIN_ALLOW_THREADS
    walk_rows(&g, &wk, g.pm.n_states, g.pm.radix, 0, nchunks, c0, c1, absmax_row, &p);
    Py_END_ALLOW_THREADS
    return close_walk(PyFloat_FromDouble(p.best), &wk, b, 6);
}

/* columns of the greedy pass's statistics (sweeps.F_*, I_*) */
enum { F_UP_SUM, F_UP_MAX, F_UP_MIN, F_LOW_SUM, F_LOW_MAX, F_LOW_MIN, F_GAP_SUM, F_GAP_MAX,
       F_LOSS_MAX, F_LEN };
enum { I_UP_ARGMIN, I_LOW_ARGMIN, I_OPTIMAL, I_DIFFERS, I_SUBOPT, I_LEN };

/* numba's ndarray.max of q[0..n): the first NaN, else the first maximum */
Py_LOCAL_INLINE(double) array_max(const double *q, int n) {
    double best = q[0];
    if (isnan(best))
        return best;
    for (int i = 1; i < n; i++) {
        if (isnan(q[i]))
            return q[i];
        if (q[i] > best)
            best = q[i];
    }
    return best;
}

typedef struct {
    const double *probs, *inc, *pent, *v, *w_low, *v_up;
    double lam, tie_rtol, loss_tol;
    const int32_t *lab32;
    const int64_t *lab64;
    const int8_t *pistar;
    int8_t *pi_s;
    double *fstats;
    int64_t *istats;
} GreedyCtx;

/* pi_s[x] and the state's share of the statistics (sweeps._greedy_record) */
Py_LOCAL_INLINE(void) greedy_record(const GreedyCtx *p, int64_t x, const double *qv,
                                    const double *qw, int n_act, int64_t k, double *f,
                                    int64_t *st) {
    double best_v = array_max(qv, n_act);
    double best_w = array_max(qw, n_act);
    double aw = fabs(best_w), av = fabs(best_v);
    double thr_w = best_w - p->tie_rtol * (aw > 1.0 ? aw : 1.0);
    int a_s = 0;
    while (a_s < n_act - 1 && qw[a_s] < thr_w)
        a_s += 1;
    p->pi_s[x] = (int8_t)a_s;
    if (qv[a_s] >= best_v - p->tie_rtol * (av > 1.0 ? av : 1.0))
        st[I_OPTIMAL] += 1;
    double loss = best_v - qv[a_s];
    f[F_LOSS_MAX] = FOLD_MAX(f[F_LOSS_MAX], loss);
    if (loss > p->loss_tol)
        st[I_SUBOPT] += 1;
    if (a_s != p->pistar[x])
        st[I_DIFFERS] += 1;
    double up = p->v_up[k] - p->v[x];
    double low = p->v[x] - p->w_low[k];
    f[F_UP_SUM] += up;
    f[F_UP_MAX] = FOLD_MAX(f[F_UP_MAX], up);
    if (up < f[F_UP_MIN]) {
        f[F_UP_MIN] = up;
        st[I_UP_ARGMIN] = x;
    }
    f[F_LOW_SUM] += low;
    f[F_LOW_MAX] = FOLD_MAX(f[F_LOW_MAX], low);
    if (low < f[F_LOW_MIN]) {
        f[F_LOW_MIN] = low;
        st[I_LOW_ARGMIN] = x;
    }
    double gap = p->v_up[k] - p->w_low[k];
    f[F_GAP_SUM] += gap;
    f[F_GAP_MAX] = FOLD_MAX(f[F_GAP_MAX], gap);
}

#define LABEL(p, s) ((p)->lab64 ? (p)->lab64[s] : (int64_t)(p)->lab32[s])

/* a whole row (chunks start at row boundaries): the sums of V*, then per state the Q-values
 * of V* and of the lifted w_low, in outcome order (sweeps.greedy_pass) */
static int greedy_row(void *ctx, const Geo *g, Walk *wk, int64_t c, int64_t plane,
                      const Row *rw, int64_t x, int64_t nb) {
    const GreedyCtx *p = ctx;
    int64_t n_out = g->pm.m + 1, gamma = g->pm.gamma, R = g->pm.radix;
    double *f = p->fstats + c * F_LEN;
    int64_t *st = p->istats + c * I_LEN;
    double inc_d = p->inc[PL(plane, P_D)];
    row_sums(p->v, p->probs, n_out, wk, nb, gamma, rw->loiter == NEVER ? 3 : 7);
    for (int64_t t = 0; t < nb; t++) {
        double qv[3], qw[3];
        double pen = p->pent[t > rw->pmax ? t : rw->pmax];
        int n_act = loiter_at(rw->loiter, t) ? 3 : 2;
        for (int a = 0; a < n_act; a++) {
            double r = a == 2 ? pen + inc_d : pen;
            qv[a] = r + p->lam * wk->acc[a * R + t];
            double lifted = 0.0;
            for (int64_t o = 0; o < n_out; o++)
                lifted += p->probs[o] * p->w_low[LABEL(p, succ_index(wk, a, o, t, gamma))];
            qw[a] = r + p->lam * lifted;
        }
        greedy_record(p, x + t, qv, qw, n_act, LABEL(p, x + t), f, st);
    }
    return 0;
}

/* labels read as partitions: entries in [0, n_parts) (ValueError naming the first not) */
static int labels_ok(const Buf *lab, int64_t n_parts) {
    Py_ssize_t n = lab->b.shape[0];
    for (Py_ssize_t i = 0; i < n; i++) {
        int64_t k = buf_int(lab, i);
        if (k < 0 || k >= n_parts) {
            PyErr_Format(PyExc_ValueError, "labels[%zd] = %lld is not a partition 0..%lld", i,
                         (long long)k, (long long)(n_parts - 1));
            return -1;
        }
    }
    return 0;
}

PyDoc_STRVAR(greedy_pass_doc,
             "greedy_pass(geo, planes, sp, weights, probs, inc, pent, discount, v, labels, "
             "w_low, v_up, pistar, tie_rtol, loss_tol, pi_s, fstats, istats, nchunks, c0, c1)"
             "\n\nOne pass over the chunks c0 <= c < c1: pi_s (int8) greedy w.r.t. the lifted "
             "w_low, and per chunk c the statistics fstats[c] (9 floats) and istats[c] (5 "
             "int64) of lpbounds.patrol.sweeps (F_*, I_*). Releases the GIL.");

static PyObject *greedy_pass(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o[15];
    GreedyCtx p;
    Py_ssize_t nchunks, c0, c1;
    if (!PyArg_ParseTuple(args, "OOOOOOOdOOOOOddOOOnnn", &o[0], &o[1], &o[2], &o[3], &o[4],
                          &o[5], &o[6], &p.lam, &o[7], &o[8], &o[9], &o[10], &o[11], &p.tie_rtol,
                          &p.loss_tol, &o[12], &o[13], &o[14], &nchunks, &c0, &c1))
        return NULL;
    Buf b[15];
    memset(b, 0, sizeof b);
    Geo g;
    Walk wk;
    static const char *const names[8] = {"v", "labels", "w_low", "v_up", "pistar", "pi_s",
                                         "fstats", "istats"};
    static const char kinds[8] = {'f', 'i', 'f', 'f', 'i', 'i', 'f', 'i'};
    static const int sizes[8] = {0, S_IDX, 0, 0, 1, 1, 0, 8};
    if (open_walk(o, b, &g, &wk, nchunks, c0, c1) || load_floats(o[4], o[5], o[6], b + 4, &g))
        return close_walk(NULL, &wk, b, 15);
    for (int i = 0; i < 8; i++)
        if (get(o[7 + i], &b[7 + i], names[i], i < 6 ? 1 : 2, kinds[i], sizes[i], i >= 5, 0))
            return close_walk(NULL, &wk, b, 15);
    Py_ssize_t n = b[7].b.shape[0], n_parts = b[9].b.shape[0];
    if (at_most_states(&b[7], "v", &g) || check_shape(&b[8], "labels", n, -1) ||
        check_shape(&b[10], "v_up", n_parts, -1) || check_shape(&b[11], "pistar", n, -1) ||
        check_shape(&b[12], "pi_s", n, -1) || check_shape(&b[13], "fstats", nchunks, F_LEN) ||
        check_shape(&b[14], "istats", nchunks, I_LEN) || labels_ok(&b[8], n_parts))
        return close_walk(NULL, &wk, b, 15);
    p.probs = b[4].b.buf;
    p.inc = b[5].b.buf;
    p.pent = b[6].b.buf;
    p.v = b[7].b.buf;
    p.lab32 = b[8].b.itemsize == 4 ? b[8].b.buf : NULL;
    p.lab64 = b[8].b.itemsize == 8 ? b[8].b.buf : NULL;
    p.w_low = b[9].b.buf;
    p.v_up = b[10].b.buf;
    p.pistar = b[11].b.buf;
    p.pi_s = b[12].b.buf;
    p.fstats = b[13].b.buf;
    p.istats = b[14].b.buf;
    Py_BEGIN_ALLOW_THREADS
    for (int64_t c = c0; c < c1; c++) { /* numba's _greedy_init */
        double *f = p.fstats + c * F_LEN;
        int64_t *st = p.istats + c * I_LEN;
        for (int i = 0; i < F_LEN; i++)
            f[i] = 0.0;
        f[F_UP_MIN] = f[F_LOW_MIN] = INFINITY;
        f[F_UP_MAX] = f[F_LOW_MAX] = f[F_GAP_MAX] = f[F_LOSS_MAX] = -INFINITY;
        for (int i = 0; i < I_LEN; i++)
            st[i] = 0;
    }
    walk_rows(&g, &wk, n, g.pm.radix, 0, nchunks, c0, c1, greedy_row, &p);
    Py_END_ALLOW_THREADS
    return close_walk(Py_NewRef(Py_None), &wk, b, 15);
}

/* columns of the V_sub pass's statistics (sweeps.S_*, J_*) */
enum { S_SUM, S_MAX, S_MIN, S_LOW_MIN, S_LEN };
enum { J_ARGMAX, J_ARGMIN, J_LOW_ARGMIN, J_LEN };

typedef struct {
    const double *vstar, *vsub, *w_low;
    double *fstats;
    int64_t *istats;
} VsubCtx;

static int vsub_row(void *ctx, const Geo *g, Walk *Py_UNUSED(wk), int64_t c, int64_t plane,
                    const Row *rw, int64_t x, int64_t nb) {
    const VsubCtx *p = ctx;
    double *f = p->fstats + c * S_LEN;
    int64_t *st = p->istats + c * J_LEN;
    for (int64_t i = 0; i < nb; i++) {
        int64_t xi = x + i;
        double diff = p->vstar[xi] - p->vsub[xi];
        f[S_SUM] += diff;
        if (diff > f[S_MAX]) {
            f[S_MAX] = diff;
            st[J_ARGMAX] = xi;
        }
        if (diff < f[S_MIN]) {
            f[S_MIN] = diff;
            st[J_ARGMIN] = xi;
        }
        double low = p->vsub[xi] - p->w_low[label_of(g, plane, rw, rw->t0 + i)];
        if (low < f[S_LOW_MIN]) {
            f[S_LOW_MIN] = low;
            st[J_LOW_ARGMIN] = xi;
        }
    }
    return 0;
}

PyDoc_STRVAR(vsub_pass_doc,
             "vsub_pass(geo, planes, sp, weights, vstar, vsub, w_low, fstats, istats, "
             "nchunks, c0, c1)\n\nPer chunk c0 <= c < c1: the sum, max and min of vstar - vsub"
             " (the last two with their states) and the smallest vsub - w_low (the lifted "
             "lower bound) with its state, into fstats[c] (4 floats) and istats[c] (3 int64). "
             "Releases the GIL.");

static PyObject *vsub_pass(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o[9];
    Py_ssize_t nchunks, c0, c1;
    if (!PyArg_ParseTuple(args, "OOOOOOOOOnnn", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6],
                          &o[7], &o[8], &nchunks, &c0, &c1))
        return NULL;
    Buf b[9];
    memset(b, 0, sizeof b);
    Geo g;
    Walk wk;
    if (open_walk(o, b, &g, &wk, nchunks, c0, c1) ||
        get(o[4], &b[4], "vstar", 1, 'f', 0, 0, 0) ||
        get(o[5], &b[5], "vsub", 1, 'f', 0, 0, 0) ||
        get(o[6], &b[6], "w_low", 1, 'f', 0, 0, 0) ||
        get(o[7], &b[7], "fstats", 2, 'f', 0, 1, 0) ||
        get(o[8], &b[8], "istats", 2, 'i', 8, 1, 0) || at_most_states(&b[4], "vstar", &g) ||
        check_shape(&b[5], "vsub", b[4].b.shape[0], -1) ||
        check_shape(&b[6], "w_low", g.pm.n_partitions, -1) ||
        check_shape(&b[7], "fstats", nchunks, S_LEN) ||
        check_shape(&b[8], "istats", nchunks, J_LEN))
        return close_walk(NULL, &wk, b, 9);
    VsubCtx p = {b[4].b.buf, b[5].b.buf, b[6].b.buf, b[7].b.buf, b[8].b.buf};
    Py_BEGIN_ALLOW_THREADS
    for (int64_t c = c0; c < c1; c++) {
        double *f = p.fstats + c * S_LEN;
        int64_t *st = p.istats + c * J_LEN;
        f[S_SUM] = 0.0;
        f[S_MAX] = -INFINITY;
        f[S_MIN] = f[S_LOW_MIN] = INFINITY;
        for (int i = 0; i < J_LEN; i++)
            st[i] = 0;
    }
    walk_rows(&g, &wk, b[4].b.shape[0], g.pm.radix, 0, nchunks, c0, c1, vsub_row, &p);
    Py_END_ALLOW_THREADS
    return close_walk(Py_NewRef(Py_None), &wk, b, 9);
}

/* ------------------------------------------------------------------ the model's kernels */
PyDoc_STRVAR(decode_states_doc,
             "decode_states(x, n_travel, radix, m, D, stations, l, w, d, tau, start, end)\n\n"
             "The components of states x[i], start <= i < end, into l, w, d (int64) and tau "
             "(int16, (n, m)): lpbounds.patrol.model's encoding. A ValueError names an x[i] "
             "that is not a state. Releases the GIL.");

static PyObject *decode_states(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_x, *o_st, *o_l, *o_w, *o_d, *o_tau;
    long long n_travel, radix, m, big_d;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OLLLLOOOOOnn", &o_x, &n_travel, &radix, &m, &big_d, &o_st,
                          &o_l, &o_w, &o_d, &o_tau, &start, &end))
        return NULL;
    Buf b[6];
    memset(b, 0, sizeof b);
    PyObject *res = NULL;
    PModel pm;
    memset(&pm, 0, sizeof pm);
    if (get(o_x, &b[0], "x", 1, 'i', 8, 0, 0) ||
        get(o_st, &b[1], "stations", 1, 'i', 8, 0, 0) ||
        get(o_l, &b[2], "l", 1, 'i', 8, 1, 0) || get(o_w, &b[3], "w", 1, 'i', 8, 1, 0) ||
        get(o_d, &b[4], "d", 1, 'i', 8, 1, 0) ||
        get(o_tau, &b[5], "tau", 2, 'i', 2, 1, 0))
        goto done;
    Py_ssize_t n = b[0].b.shape[0];
    pm.m = m;
    pm.D = big_d;
    pm.radix = radix;
    pm.n_travel = n_travel;
    int ok = radix >= 2 && m >= 1 && m <= PATROL_MMAX && big_d >= 1 && n_travel >= 0 &&
             radix - 1 <= INT16_MAX && pow_ok(radix, m, &pm.rm);
    int64_t t;
    pm.rm1 = ok ? pm.rm / radix : 0;
    ok = ok && mul_ok(m * big_d, pm.rm1, &t) && add_ok(n_travel, t, &pm.n_states);
    if (!ok) {
        PyErr_Format(PyExc_ValueError, "decode_states: sizes n_travel = %lld, radix = %lld, "
                     "m = %lld, D = %lld are not a patrol encoding", n_travel, radix, m, big_d);
        goto done;
    }
    if (check_shape(&b[1], "stations", m, -1) || check_shape(&b[2], "l", n, -1) ||
        check_shape(&b[3], "w", n, -1) || check_shape(&b[4], "d", n, -1) ||
        check_shape(&b[5], "tau", n, m) || check_range(start, end, n))
        goto done;
    const int64_t *x = b[0].b.buf;
    for (Py_ssize_t i = start; i < end; i++)
        if (x[i] < 0 || x[i] >= pm.n_states) {
            PyErr_Format(PyExc_ValueError, "x[%zd] = %lld is not a state 0..%lld", i,
                         (long long)x[i], (long long)(pm.n_states - 1));
            goto done;
        }
    pm.stations = b[1].b.buf;
    int64_t *l = b[2].b.buf, *w = b[3].b.buf, *d = b[4].b.buf;
    int16_t *tau = b[5].b.buf;
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t i = start; i < end; i++) {
        int16_t *ti = tau + (size_t)i * m;
#define TAU_I(j) ti[j]
        int64_t li, wi, di;
        DECODE_ONE(&pm, x[i], li, wi, di, TAU_I);
        l[i] = li;
        w[i] = wi;
        d[i] = di;
#undef TAU_I
    }
    Py_END_ALLOW_THREADS
    res = Py_NewRef(Py_None);
done:
    release(b, 6);
    return res;
}

PyDoc_STRVAR(successor_states_doc,
             "successor_states(l, w, d, tau, action, N, D, Gamma, radix, n_travel, station_pos,"
             " w_travel, w_loiter, out, start, end)\n\nThe successors of decoded states i, "
             "start <= i < end, under one action into out (int64, (n, m + 1)): no alert, then an"
             " alert at station j (column j + 1); lpbounds.patrol.model's dynamics. A loiter "
             "needs a station with d < D (ValueError naming the state). Releases the GIL.");

static PyObject *successor_states(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_l, *o_w, *o_d, *o_tau, *o_sp, *o_wt, *o_wl, *o_out;
    long long action, n_nodes, big_d, gamma, radix, n_travel;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOOLLLLLLOOOOnn", &o_l, &o_w, &o_d, &o_tau, &action, &n_nodes,
                          &big_d, &gamma, &radix, &n_travel, &o_sp, &o_wt, &o_wl, &o_out, &start,
                          &end))
        return NULL;
    Buf b[8];
    memset(b, 0, sizeof b);
    PyObject *res = NULL;
    PModel pm;
    memset(&pm, 0, sizeof pm);
    if (get(o_l, &b[0], "l", 1, 'i', 8, 0, 0) || get(o_w, &b[1], "w", 1, 'i', 8, 0, 0) ||
        get(o_d, &b[2], "d", 1, 'i', 8, 0, 0) ||
        get(o_tau, &b[3], "tau", 2, 'i', 2, 0, 0) ||
        get(o_sp, &b[4], "station_pos", 1, 'i', 8, 0, 0) ||
        get(o_wt, &b[5], "w_travel", 1, 'i', 8, 0, 0) ||
        get(o_wl, &b[6], "w_loiter", 2, 'i', 8, 0, 0) ||
        get(o_out, &b[7], "out", 2, 'i', 8, 1, 0))
        goto done;
    Py_ssize_t n = b[0].b.shape[0], m = b[3].b.shape[1];
    if (action < 0 || action > 2 || n_nodes < 1 || big_d < 1 || m < 1 || m > PATROL_MMAX) {
        PyErr_Format(PyExc_ValueError, "successor_states: action = %lld (0, 1 or 2), N = %lld,"
                     " D = %lld (>= 1), m = %zd", action, n_nodes, big_d, m);
        goto done;
    }
    if (check_shape(&b[1], "w", n, -1) || check_shape(&b[2], "d", n, -1) ||
        check_shape(&b[3], "tau", n, m) || check_shape(&b[4], "station_pos", n_nodes, -1) ||
        check_shape(&b[5], "w_travel", m, -1) || check_shape(&b[6], "w_loiter", m, m) ||
        check_shape(&b[7], "out", n, m + 1) || check_range(start, end, n))
        goto done;
    const int64_t *l = b[0].b.buf, *w = b[1].b.buf, *d = b[2].b.buf, *sp = b[4].b.buf;
    for (Py_ssize_t i = start; i < end; i++) {
        int bad = l[i] < 0 || l[i] >= n_nodes;
        if (!bad && action == 2)
            bad = sp[l[i]] < 0 || sp[l[i]] >= m || d[i] < 0 || d[i] >= big_d;
        if (bad) {
            PyErr_Format(PyExc_ValueError, "state %zd (l = %lld, d = %lld): %s", i,
                         (long long)l[i], (long long)d[i],
                         action == 2 ? "loiter needs a station with d < D" : "l is not a node");
            goto done;
        }
    }
    pm.N = n_nodes;
    pm.m = m;
    pm.D = big_d;
    pm.gamma = gamma;
    pm.radix = radix;
    pm.n_travel = n_travel;
    if (radix < 2 || !pow_ok(radix, m, &pm.rm)) {
        PyErr_Format(PyExc_ValueError, "successor_states: radix = %lld, m = %zd: R^m is not an "
                     "int64", radix, m);
        goto done;
    }
    pm.rm1 = pm.rm / radix;
    pm.station_pos = sp;
    pm.w_travel = b[5].b.buf;
    pm.w_loiter = b[6].b.buf;
    const int16_t *tau = b[3].b.buf;
    int64_t *out = b[7].b.buf;
    int a = (int)action;
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t i = start; i < end; i++) {
        const int16_t *ti = tau + (size_t)i * m;
        int64_t *oi = out + (size_t)i * (m + 1);
#define TAU_I(j) ((int64_t)ti[j])
#define OUT_I(j) oi[j]
        SUCCESSORS_ONE(&pm, l[i], w[i], d[i], TAU_I, a, OUT_I);
#undef TAU_I
#undef OUT_I
    }
    Py_END_ALLOW_THREADS
    res = Py_NewRef(Py_None);
done:
    release(b, 8);
    return res;
}

/* the arguments of a key: 0 <= l < N; a loiter key at a station */
static int key_args_ok(long long l, long long d, const Buf *sp, long long m) {
    if (m < 1 || m > PATROL_MMAX || l < 0 || l >= sp->b.shape[0]) {
        PyErr_Format(PyExc_ValueError, "a partition key needs 0 <= l < N = %zd and "
                     "1 <= m <= %d; got l = %lld, m = %lld", sp->b.shape[0], PATROL_MMAX, l, m);
        return -1;
    }
    int64_t k = ((const int64_t *)sp->b.buf)[l];
    if (d != 0 && (k < 0 || k >= m)) {
        PyErr_Format(PyExc_ValueError, "a loiter key (d = %lld) needs a station: "
                     "station_pos[%lld] = %lld", d, l, (long long)k);
        return -1;
    }
    return 0;
}

PyDoc_STRVAR(key_index_doc,
             "key_index(l, w, d, acode, tb, station_pos, N, D, Gamma, tb_size, lb_size, m) "
             "-> int\n\nlpbounds.patrol.partitions.partition_index of one key: acode the alert"
             " pattern (station 0 the most significant of m bits), tb the largest delay.");

static PyObject *key_index_py(PyObject *Py_UNUSED(self), PyObject *args) {
    long long l, w, d, acode, tb, n_nodes, big_d, gamma, tbs, lbs, m;
    PyObject *o_sp;
    if (!PyArg_ParseTuple(args, "LLLLLOLLLLLL", &l, &w, &d, &acode, &tb, &o_sp, &n_nodes, &big_d,
                          &gamma, &tbs, &lbs, &m))
        return NULL;
    Buf b[1];
    memset(b, 0, sizeof b);
    PyObject *res = NULL;
    if (get(o_sp, &b[0], "station_pos", 1, 'i', 8, 0, 0) || key_args_ok(l, d, &b[0], m))
        goto done;
    res = PyLong_FromLongLong(key_index(l, w, d, acode, tb, b[0].b.buf, n_nodes, big_d, gamma,
                                        tbs, lbs, m));
done:
    release(b, 1);
    return res;
}

/* (acode, taubar) of a delay vector (alert_key_kernel) */
static void alert_key(const Buf *tau, int64_t *acode, int64_t *tb) {
    int64_t a = 0, t = 0;
    for (Py_ssize_t j = 0; j < tau->b.shape[0]; j++) {
        int64_t v = buf_int(tau, j);
        a = 2 * a + (v > 0 ? 1 : 0);
        if (v > t)
            t = v;
    }
    *acode = a;
    *tb = t;
}

PyDoc_STRVAR(alert_key_doc,
             "alert_key(tau) -> (acode, taubar)\n\nThe alert pattern (station 0 the most "
             "significant bit) and the largest delay of one delay vector.");

static PyObject *alert_key_py(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_tau;
    if (!PyArg_ParseTuple(args, "O", &o_tau))
        return NULL;
    Buf b[1];
    memset(b, 0, sizeof b);
    if (get(o_tau, &b[0], "tau", 1, 'i', S_ANY, 0, 0)) {
        release(b, 1);
        return NULL;
    }
    if (b[0].b.shape[0] > PATROL_MMAX) {
        PyErr_Format(PyExc_ValueError, "tau: %zd delays, more than %d stations",
                     b[0].b.shape[0], PATROL_MMAX);
        release(b, 1);
        return NULL;
    }
    int64_t acode, tb;
    alert_key(&b[0], &acode, &tb);
    release(b, 1);
    return Py_BuildValue("LL", (long long)acode, (long long)tb);
}

PyDoc_STRVAR(state_partition_doc,
             "state_partition(l, w, d, tau, station_pos, N, D, Gamma, tb_size, lb_size) -> "
             "int\n\nThe partition of one state given by its components (tau its delay "
             "vector, length m).");

static PyObject *state_partition_py(PyObject *Py_UNUSED(self), PyObject *args) {
    long long l, w, d, n_nodes, big_d, gamma, tbs, lbs;
    PyObject *o_tau, *o_sp;
    if (!PyArg_ParseTuple(args, "LLLOOLLLLL", &l, &w, &d, &o_tau, &o_sp, &n_nodes, &big_d, &gamma,
                          &tbs, &lbs))
        return NULL;
    Buf b[2];
    memset(b, 0, sizeof b);
    PyObject *res = NULL;
    if (get(o_tau, &b[0], "tau", 1, 'i', S_ANY, 0, 0) ||
        get(o_sp, &b[1], "station_pos", 1, 'i', 8, 0, 0) ||
        key_args_ok(l, d, &b[1], (long long)b[0].b.shape[0]))
        goto done;
    int64_t acode, tb;
    alert_key(&b[0], &acode, &tb);
    res = PyLong_FromLongLong(key_index(l, w, d, acode, tb, b[1].b.buf, n_nodes, big_d, gamma,
                                        tbs, lbs, b[0].b.shape[0]));
done:
    release(b, 2);
    return res;
}

static PyMethodDef methods[] = {
    {"max_sweep", max_sweep, METH_VARARGS, max_sweep_doc},
    {"policy_sweep", policy_sweep, METH_VARARGS, policy_sweep_doc},
    {"labels_pass", labels_pass, METH_VARARGS, labels_pass_doc},
    {"decode_range", decode_range, METH_VARARGS, decode_range_doc},
    {"successor_range", successor_range, METH_VARARGS, successor_range_doc},
    {"check_policy_pass", check_policy_pass, METH_VARARGS, check_policy_pass_doc},
    {"reward_absmax_pass", reward_absmax_pass, METH_VARARGS, reward_absmax_pass_doc},
    {"greedy_pass", greedy_pass, METH_VARARGS, greedy_pass_doc},
    {"vsub_pass", vsub_pass, METH_VARARGS, vsub_pass_doc},
    {"decode_states", decode_states, METH_VARARGS, decode_states_doc},
    {"successor_states", successor_states, METH_VARARGS, successor_states_doc},
    {"key_index", key_index_py, METH_VARARGS, key_index_doc},
    {"alert_key", alert_key_py, METH_VARARGS, alert_key_doc},
    {"state_partition", state_partition_py, METH_VARARGS, state_partition_doc},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "patrolsweeps",
    "The patrol's matrix-free sweeps, its encoding and partition key, compiled ahead of time "
    "(see lpbounds.patrol.sweeps).",
    -1, methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit_patrolsweeps(void) { return PyModule_Create(&module); }

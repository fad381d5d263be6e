/* The Bellman-row sweeps of lpbounds.rows, compiled ahead of time (the hot loop of exact DP).
 *
 * Every function works on one range of owners (or rows) and releases the GIL, so that
 * lpbounds._kernels.native runs one range per thread. The arithmetic is that of the numpy
 * twins (lpbounds._kernels.twins), term by term: row r reads
 *
 *     acc = 0.0;  acc += probs[r, l] * v[targets[r, l]]   for l = 0 .. L-1, in order;
 *     q_r = reward[r] + discount * acc
 *
 * with no fused multiply-add (built with -ffp-contract=off, see setup.py) and no
 * reassociation, so every number is bit-identical to theirs (tests/test_fast_paths.py).
 * The first maximising row of an owner is kept (strict >); the extremes of out - v are
 * exact minima and maxima, whatever the ranges.
 *
 * Arrays come through the buffer protocol (no numpy headers at build time): float64,
 * int32 / int64, C-contiguous, except probs, which may be any strided 2-D float64 view
 * (a broadcast row, stride 0, when all rows share one distribution: then the L
 * probabilities are read once and the row loop is unrolled for L <= 8).
 *
 * Every index is checked before it is used, so that no input reaches memory outside its
 * array (the module is importable; the public constructors validate first, but a direct
 * call must not crash the interpreter): indptr within [0, R] and not decreasing, a target
 * within [0, len(v)), an entry of rows / sel within [0, R). The owners are swept in blocks
 * of BLOCK; a target is checked as it is read (Q_CHECKED), except in the improvement sweep
 * with a shared distribution, which checks its block's targets first (check_targets) and
 * then sweeps it from cache. The arithmetic, and so every number, is unchanged. A bad
 * index stops the sweep and raises IndexError (targets, rows, sel) or ValueError
 * (indptr); the output arrays may then be partly written. The checks' cost beside the
 * sweeps is measured in lpbounds._kernels.native's docstring.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "buffers.h"

/* The rows' data as the loops read it. */
typedef struct {
    const double *reward;
    const char *targets; /* int32 or int64, rows of L */
    const char *probs;   /* rows of L at strides ps0, ps1 */
    Py_ssize_t ps0, ps1, L, R;
    double lam;
    const double *v;
    Py_ssize_t nv; /* entries of v: every target must be below */
} Rows;

/* The first bad index a sweep met (what: 0 none, 't' a target, 'p' an entry of indptr). */
typedef struct {
    int what;
    Py_ssize_t i, l;
    long long value;
} Bad;

/* q = q_r; TT the target type, LL the outcome count (a constant or rw->L), P(l) the l-th
 * probability of row r. Q_ROW reads targets checked before (check_targets); Q_CHECKED
 * checks each target as it reads it, leaving the block (goto stop) at one outside
 * [0, nv_): a branch that is never taken on valid rows, and no load depends on it, so
 * the arithmetic is that of Q_ROW. Which is cheaper depends on the loop (measured in
 * lpbounds._kernels.native's docstring): the improvement sweep with a shared
 * distribution is slowed by the branch, and checks its block first instead. */
#define Q_ROW(TT, LL, P, q)                                                               \
    do {                                                                                  \
        const TT *t_ = (const TT *)rw->targets + (size_t)r * (LL);                       \
        double acc_ = 0.0;                                                                \
        for (Py_ssize_t l = 0; l < (LL); l++)                                             \
            acc_ += P(l) * rw->v[t_[l]];                                                  \
        q = rw->reward[r] + rw->lam * acc_;                                               \
    } while (0)
#define Q_CHECKED(TT, LL, P, q)                                                           \
    do {                                                                                  \
        const TT *t_ = (const TT *)rw->targets + (size_t)r * (LL);                       \
        double acc_ = 0.0;                                                                \
        for (Py_ssize_t l = 0; l < (LL); l++) {                                           \
            const size_t k_ = (size_t)(Py_ssize_t)t_[l];                                  \
            if (k_ >= nv_)                                                                \
                goto stop;                                                                \
            acc_ += P(l) * rw->v[k_];                                                     \
        }                                                                                 \
        q = rw->reward[r] + rw->lam * acc_;                                               \
    } while (0)
#define P_ROW(l) (*(const double *)(rw->probs + r * rw->ps0 + (l) * rw->ps1))
#define P_SHARED(l) (p_[l])

/* owners [start, end): out[i] = max_r q_r, arg[i] = first maximising row; extremes of
 * out - v into *lo, *hi */
#define MAX_LOOP(TT, LL, P, Q)                                                            \
    for (Py_ssize_t i = start; i < end; i++) {                                            \
        double best = -INFINITY;                                                          \
        int64_t best_r = -1;                                                              \
        for (int64_t r = indptr[i]; r < indptr[i + 1]; r++) {                             \
            double q;                                                                     \
            Q(TT, LL, P, q);                                                              \
            if (q > best) {                                                               \
                best = q;                                                                 \
                best_r = r;                                                               \
            }                                                                             \
        }                                                                                 \
        out[i] = best;                                                                    \
        arg[i] = best_r;                                                                  \
        double d = best - rw->v[i];                                                       \
        if (d < lc)                                                                       \
            lc = d;                                                                       \
        if (d > hc)                                                                       \
            hc = d;                                                                       \
    }

/* owners [start, end): out[i] = q_{rows[i]} (rows NULL: row i) */
#define POLICY_LOOP(TT, LL, P, Q)                                                         \
    for (Py_ssize_t i = start; i < end; i++) {                                            \
        int64_t r = rows ? rows[i] : (int64_t)i;                                          \
        double q;                                                                         \
        Q(TT, LL, P, q);                                                                  \
        out[i] = q;                                                                       \
        double d = q - rw->v[i];                                                          \
        if (d < lc)                                                                       \
            lc = d;                                                                       \
        if (d > hc)                                                                       \
            hc = d;                                                                       \
    }

/* whether the rows share one distribution of 1..8 outcomes (the unrolled loops) */
#define UNROLLED(rw) ((rw)->ps0 == 0 && (rw)->L >= 1 && (rw)->L <= 8 && (rw)->R > 0)

/* one loop body per (target type, shared probabilities unrolled for L <= 8, general);
 * QS, QR: the row macro of the unrolled and of the general loops */
#define DISPATCH(LOOP, TT, QS, QR)                                                        \
    if (UNROLLED(rw)) {                                                                   \
        double p_[8];                                                                     \
        for (Py_ssize_t l = 0; l < rw->L; l++)                                            \
            p_[l] = *(const double *)(rw->probs + l * rw->ps1);                           \
        switch (rw->L) {                                                                  \
        case 1: LOOP(TT, 1, P_SHARED, QS) break;                                          \
        case 2: LOOP(TT, 2, P_SHARED, QS) break;                                          \
        case 3: LOOP(TT, 3, P_SHARED, QS) break;                                          \
        case 4: LOOP(TT, 4, P_SHARED, QS) break;                                          \
        case 5: LOOP(TT, 5, P_SHARED, QS) break;                                          \
        case 6: LOOP(TT, 6, P_SHARED, QS) break;                                          \
        case 7: LOOP(TT, 7, P_SHARED, QS) break;                                          \
        default: LOOP(TT, 8, P_SHARED, QS) break;                                         \
        }                                                                                 \
    } else {                                                                              \
        LOOP(TT, rw->L, P_ROW, QR)                                                        \
    }

/* The first target of rows [r0, r1) outside [0, nv) into *bad; 1 if there is one. A scan
 * with no branch first (an OR of "outside" over the targets read as unsigned, so that a
 * negative one is outside too: compilers vectorise it), the search only when it finds one. */
static int check_targets(const Rows *rw, int t64, int64_t r0, int64_t r1, Bad *bad) {
    size_t a = (size_t)r0 * rw->L, b = (size_t)r1 * rw->L, nv = (size_t)rw->nv;
    int out = 0;
    if (t64) {
        const uint64_t *t = (const uint64_t *)rw->targets, hi = (uint64_t)nv;
        uint64_t any = 0;
        for (size_t j = a; j < b; j++)
            any |= t[j] >= hi;
        out = any != 0;
    } else {
        /* as unsigned 32-bit: a negative target is above every count of entries */
        const uint32_t *t = (const uint32_t *)rw->targets;
        const uint32_t hi = nv > 0x7fffffffu ? 0x80000000u : (uint32_t)nv;
        uint32_t any = 0;
        for (size_t j = a; j < b; j++)
            any |= t[j] >= hi;
        out = any != 0;
    }
    if (!out)
        return 0;
    for (size_t j = a; j < b; j++) {
        long long k = t64 ? ((const int64_t *)rw->targets)[j] : ((const int32_t *)rw->targets)[j];
        if (k < 0 || (size_t)k >= nv) {
            bad->what = 't';
            bad->i = (Py_ssize_t)(j / (size_t)rw->L);
            bad->l = (Py_ssize_t)(j % (size_t)rw->L);
            bad->value = k;
            return 1;
        }
    }
    return 0;
}

/* Owners per block: a block is checked (its indptr; its targets, where the sweep does
 * not check them as it goes), then swept while they are in cache. */
#define BLOCK 256

/* owners [start, end): 1 when a target outside [0, nv) stopped the sweep (the general
 * loop's; the unrolled loop's targets were checked before) */
static int max_block(const Rows *rw, int t64, const int64_t *indptr, double *out,
                     int64_t *arg, Py_ssize_t start, Py_ssize_t end, double *lo, double *hi) {
    double lc = *lo, hc = *hi;
    const size_t nv_ = (size_t)rw->nv;
    int hit = 0;
    if (t64) {
        DISPATCH(MAX_LOOP, int64_t, Q_ROW, Q_CHECKED)
    } else {
        DISPATCH(MAX_LOOP, int32_t, Q_ROW, Q_CHECKED)
    }
    goto done;
stop:
    hit = 1;
done:
    *lo = lc;
    *hi = hc;
    return hit;
}

/* owners [start, end): 1 when a target outside [0, nv) stopped the sweep */
static int policy_block(const Rows *rw, int t64, const int64_t *rows, double *out,
                        Py_ssize_t start, Py_ssize_t end, double *lo, double *hi) {
    double lc = *lo, hc = *hi;
    const size_t nv_ = (size_t)rw->nv;
    int hit = 0;
    if (t64) {
        DISPATCH(POLICY_LOOP, int64_t, Q_CHECKED, Q_CHECKED)
    } else {
        DISPATCH(POLICY_LOOP, int32_t, Q_CHECKED, Q_CHECKED)
    }
    goto done;
stop:
    hit = 1;
done:
    *lo = lc;
    *hi = hc;
    return hit;
}

/* owners [start, end), block by block: indptr within [0, R] and not decreasing, the
 * targets of the block's rows within [0, nv) (before the sweep with a shared
 * distribution, during it otherwise), the sweep of the block */
static void max_range(const Rows *rw, int t64, const int64_t *indptr, double *out,
                      int64_t *arg, Py_ssize_t start, Py_ssize_t end, double *lo, double *hi,
                      Bad *bad) {
    double lc = INFINITY, hc = -INFINITY;
    for (Py_ssize_t b0 = start; b0 < end; b0 += BLOCK) {
        Py_ssize_t b1 = end - b0 > BLOCK ? b0 + BLOCK : end;
        for (Py_ssize_t i = b0; i <= b1; i++)
            if (indptr[i] < (i > start ? indptr[i - 1] : 0) || indptr[i] > rw->R) {
                bad->what = 'p';
                bad->i = i;
                bad->value = (long long)indptr[i];
                goto stop;
            }
        if ((UNROLLED(rw) && check_targets(rw, t64, indptr[b0], indptr[b1], bad)) ||
            (max_block(rw, t64, indptr, out, arg, b0, b1, &lc, &hc) &&
             check_targets(rw, t64, indptr[b0], indptr[b1], bad)))
            goto stop;
    }
stop:
    *lo = lc;
    *hi = hc;
}

/* owners [start, end), block by block (rows checked by the caller; the targets during the
 * sweep): a block stopped by a target is searched for it */
static void policy_range(const Rows *rw, int t64, const int64_t *rows, double *out,
                         Py_ssize_t start, Py_ssize_t end, double *lo, double *hi, Bad *bad) {
    double lc = INFINITY, hc = -INFINITY;
    for (Py_ssize_t b0 = start; b0 < end; b0 += BLOCK) {
        Py_ssize_t b1 = end - b0 > BLOCK ? b0 + BLOCK : end;
        if (policy_block(rw, t64, rows, out, b0, b1, &lc, &hc)) {
            for (Py_ssize_t i = b0; i < b1; i++) {
                int64_t r = rows ? rows[i] : (int64_t)i;
                if (check_targets(rw, t64, r, r + 1, bad))
                    break;
            }
            break;
        }
    }
    *lo = lc;
    *hi = hc;
}

/* Set the exception of the first bad index a sweep met: -1, or 0 when there is none. */
static int raise_bad(const Bad *bad, const Rows *rw) {
    if (bad->what == 't') {
        PyErr_Format(PyExc_IndexError,
                     "targets[%zd, %zd] = %lld is not an entry of v (0..%zd)", bad->i, bad->l,
                     bad->value, rw->nv - 1);
        return -1;
    }
    if (bad->what == 'p') {
        PyErr_Format(PyExc_ValueError,
                     "indptr[%zd] = %lld: the rows of an owner must lie within 0..%zd, "
                     "indptr not decreasing",
                     bad->i, bad->value, rw->R);
        return -1;
    }
    return 0;
}

/* the rows' buffers: reward (R,), targets (R, L), probs (R, L) strided */
static int get_rows(PyObject *reward, PyObject *targets, PyObject *probs, double lam, Buf *b,
                    Rows *rw, int *t64) {
    if (get(reward, &b[0], "reward", 1, 'f', 8, 0, 0) ||
        get(targets, &b[1], "targets", 2, 'i', 0, 0, 0) ||
        get(probs, &b[2], "probs", 2, 'f', 8, 0, 1))
        return -1;
    Py_ssize_t R = b[0].b.shape[0];
    if (b[1].b.shape[0] != R || b[2].b.shape[0] != R || b[2].b.shape[1] != b[1].b.shape[1]) {
        PyErr_SetString(PyExc_ValueError, "reward, targets and probs: rows differ");
        return -1;
    }
    rw->reward = b[0].b.buf;
    rw->targets = b[1].b.buf;
    rw->probs = b[2].b.buf;
    rw->ps0 = b[2].b.strides[0];
    rw->ps1 = b[2].b.strides[1];
    rw->L = b[1].b.shape[1];
    rw->R = R;
    rw->lam = lam;
    *t64 = b[1].b.itemsize == 8;
    return 0;
}

PyDoc_STRVAR(bellman_max_stats_doc,
             "bellman_max_stats(indptr, reward, targets, probs, discount, v, out, arg, start, end)"
             " -> (lo, hi)\n\nFor owners start <= i < end: out[i] = max of q_r over rows "
             "indptr[i]:indptr[i+1], arg[i] the first maximising row (-1 if none); returns the "
             "min and max of out[i] - v[i] over the range. Raises IndexError for a target that is "
             "not an entry of v, ValueError for an indptr outside 0..R or decreasing. Releases "
             "the GIL.");

static PyObject *bellman_max_stats(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_ip, *o_rew, *o_t, *o_p, *o_v, *o_out, *o_arg;
    double lam;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOOdOOOnn", &o_ip, &o_rew, &o_t, &o_p, &lam, &o_v, &o_out,
                          &o_arg, &start, &end))
        return NULL;
    Buf b[7];
    memset(b, 0, sizeof b);
    Rows rw;
    int t64;
    PyObject *res = NULL;
    if (get_rows(o_rew, o_t, o_p, lam, b, &rw, &t64) ||
        get(o_ip, &b[3], "indptr", 1, 'i', 8, 0, 0) || get(o_v, &b[4], "v", 1, 'f', 8, 0, 0) ||
        get(o_out, &b[5], "out", 1, 'f', 8, 1, 0) || get(o_arg, &b[6], "arg", 1, 'i', 8, 1, 0))
        goto done;
    Py_ssize_t n = b[3].b.shape[0] - 1;
    if (b[4].b.shape[0] < n || b[5].b.shape[0] < n || b[6].b.shape[0] < n) {
        PyErr_SetString(PyExc_ValueError, "v, out and arg need one entry per owner");
        goto done;
    }
    if (check_range(start, end, n))
        goto done;
    rw.v = b[4].b.buf;
    rw.nv = b[4].b.shape[0];
    double lo, hi;
    Bad bad = {0, 0, 0, 0};
    Py_BEGIN_ALLOW_THREADS
    max_range(&rw, t64, b[3].b.buf, b[5].b.buf, b[6].b.buf, start, end, &lo, &hi, &bad);
    Py_END_ALLOW_THREADS
    if (raise_bad(&bad, &rw))
        goto done;
    res = Py_BuildValue("dd", lo, hi);
done:
    release(b, 7);
    return res;
}

PyDoc_STRVAR(policy_sweep_stats_doc,
             "policy_sweep_stats(rows, reward, targets, probs, discount, v, out, start, end)"
             " -> (lo, hi)\n\nFor start <= i < end: out[i] = q_{rows[i]} (rows None: q_i, the "
             "rows packed one per owner); returns the min and max of out[i] - v[i] over the "
             "range. Raises IndexError for a row outside the rows or a target that is not an entry "
             "of v. Releases the GIL.");

static PyObject *policy_sweep_stats(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_rows, *o_rew, *o_t, *o_p, *o_v, *o_out;
    double lam;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOOdOOnn", &o_rows, &o_rew, &o_t, &o_p, &lam, &o_v, &o_out,
                          &start, &end))
        return NULL;
    Buf b[6];
    memset(b, 0, sizeof b);
    Rows rw;
    int t64;
    PyObject *res = NULL;
    int packed = o_rows == Py_None;
    if (get_rows(o_rew, o_t, o_p, lam, b, &rw, &t64) ||
        (!packed && get(o_rows, &b[3], "rows", 1, 'i', 8, 0, 0)) ||
        get(o_v, &b[4], "v", 1, 'f', 8, 0, 0) || get(o_out, &b[5], "out", 1, 'f', 8, 1, 0))
        goto done;
    Py_ssize_t n = packed ? b[5].b.shape[0] : b[3].b.shape[0], R = b[0].b.shape[0];
    if (b[4].b.shape[0] < n || b[5].b.shape[0] < n || (packed && R < n)) {
        PyErr_SetString(PyExc_ValueError, "v and out need one entry per row of rows");
        goto done;
    }
    if (check_range(start, end, n))
        goto done;
    const int64_t *rows = packed ? NULL : b[3].b.buf;
    if (rows)
        for (Py_ssize_t i = start; i < end; i++)
            if (rows[i] < 0 || rows[i] >= R) {
                PyErr_Format(PyExc_IndexError, "rows[%zd] = %lld is not a row (0..%zd)", i,
                             (long long)rows[i], R - 1);
                goto done;
            }
    rw.v = b[4].b.buf;
    rw.nv = b[4].b.shape[0];
    double lo, hi;
    Bad bad = {0, 0, 0, 0};
    Py_BEGIN_ALLOW_THREADS
    policy_range(&rw, t64, rows, b[5].b.buf, start, end, &lo, &hi, &bad);
    Py_END_ALLOW_THREADS
    if (raise_bad(&bad, &rw))
        goto done;
    res = Py_BuildValue("dd", lo, hi);
done:
    release(b, 6);
    return res;
}

PyDoc_STRVAR(gather_rows_doc,
             "gather_rows(sel, reward, targets, probs, out_reward, out_targets, out_probs, "
             "copy_probs, start, end)\n\nRow sel[i] into slot i of the out_ arrays for "
             "start <= i < end (out_probs only when copy_probs). Releases the GIL.");

static PyObject *gather_rows(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_sel, *o_rew, *o_t, *o_p, *o_orew, *o_ot, *o_op;
    int copy_probs;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOOOOOpnn", &o_sel, &o_rew, &o_t, &o_p, &o_orew, &o_ot, &o_op,
                          &copy_probs, &start, &end))
        return NULL;
    Buf b[7];
    memset(b, 0, sizeof b);
    Rows rw;
    int t64;
    if (get_rows(o_rew, o_t, o_p, 0.0, b, &rw, &t64) ||
        get(o_sel, &b[3], "sel", 1, 'i', 8, 0, 0) ||
        get(o_orew, &b[4], "out_reward", 1, 'f', 8, 1, 0) ||
        get(o_ot, &b[5], "out_targets", 2, 'i', t64 ? 8 : 4, 1, 0) ||
        (copy_probs && get(o_op, &b[6], "out_probs", 2, 'f', 8, 1, 0))) {
        release(b, 7);
        return NULL;
    }
    Py_ssize_t n = b[3].b.shape[0], L = rw.L;
    if (check_range(start, end, n) || b[4].b.shape[0] < n || b[5].b.shape[0] < n ||
        b[5].b.shape[1] != L || (copy_probs && (b[6].b.shape[0] < n || b[6].b.shape[1] != L))) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_ValueError, "gather_rows: output shapes differ from the rows'");
        release(b, 7);
        return NULL;
    }
    const int64_t *sel = b[3].b.buf;
    for (Py_ssize_t i = start; i < end; i++)
        if (sel[i] < 0 || sel[i] >= b[0].b.shape[0]) {
            PyErr_Format(PyExc_IndexError, "sel[%zd] = %lld is not a row (0..%zd)", i,
                         (long long)sel[i], b[0].b.shape[0] - 1);
            release(b, 7);
            return NULL;
        }
    double *orew = b[4].b.buf;
    char *ot = b[5].b.buf;
    double *op = copy_probs ? b[6].b.buf : NULL;
    Py_ssize_t isz = b[1].b.itemsize;
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t i = start; i < end; i++) {
        int64_t r = sel[i];
        orew[i] = rw.reward[r];
        memcpy(ot + (size_t)i * L * isz, rw.targets + (size_t)r * L * isz, (size_t)L * isz);
        if (op)
            for (Py_ssize_t l = 0; l < L; l++)
                op[i * L + l] = *(const double *)(rw.probs + r * rw.ps0 + l * rw.ps1);
    }
    Py_END_ALLOW_THREADS
    release(b, 7);
    Py_RETURN_NONE;
}

PyDoc_STRVAR(check_successors_doc,
             "check_successors(succ, allow, n, start, end) -> (bad, first, bad_disallowed)\n\n"
             "Successors outside [0, n) of the states start <= x < end of succ (S, A, L): their "
             "count on allowed pairs, the first one's flat index (-1 if none), their count on "
             "disallowed pairs. One pass, no temporaries. Releases the GIL.");

static PyObject *check_successors(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_s, *o_a;
    long long n;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOLnn", &o_s, &o_a, &n, &start, &end))
        return NULL;
    Buf b[2];
    memset(b, 0, sizeof b);
    if (get(o_s, &b[0], "succ", 3, 'i', 0, 0, 0) || get(o_a, &b[1], "allow", 2, 'b', 1, 0, 0)) {
        release(b, 2);
        return NULL;
    }
    Py_ssize_t S = b[0].b.shape[0], A = b[0].b.shape[1], L = b[0].b.shape[2];
    if (b[1].b.shape[0] != S || b[1].b.shape[1] != A || check_range(start, end, S)) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_ValueError, "succ and allow: shapes differ");
        release(b, 2);
        return NULL;
    }
    int s64 = b[0].b.itemsize == 8;
    const char *allow = b[1].b.buf;
    long long bad = 0, bad_dis = 0, first = -1;
    Py_BEGIN_ALLOW_THREADS
    for (Py_ssize_t x = start; x < end; x++)
        for (Py_ssize_t u = 0; u < A; u++) {
            size_t base = ((size_t)x * A + u) * L;
            for (Py_ssize_t l = 0; l < L; l++) {
                long long k = s64 ? ((const int64_t *)b[0].b.buf)[base + l]
                                  : ((const int32_t *)b[0].b.buf)[base + l];
                if (k < 0 || k >= n) {
                    if (allow[x * A + u]) {
                        if (first < 0)
                            first = (long long)(base + l);
                        bad++;
                    } else {
                        bad_dis++;
                    }
                }
            }
        }
    Py_END_ALLOW_THREADS
    release(b, 2);
    return Py_BuildValue("LLL", bad, first, bad_dis);
}

static PyMethodDef methods[] = {
    {"bellman_max_stats", bellman_max_stats, METH_VARARGS, bellman_max_stats_doc},
    {"policy_sweep_stats", policy_sweep_stats, METH_VARARGS, policy_sweep_stats_doc},
    {"gather_rows", gather_rows, METH_VARARGS, gather_rows_doc},
    {"check_successors", check_successors, METH_VARARGS, check_successors_doc},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "rowsweeps",
    "The Bellman-row sweeps of lpbounds, compiled ahead of time (see "
    "lpbounds._kernels.native).",
    -1, methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit_rowsweeps(void) { return PyModule_Create(&module); }

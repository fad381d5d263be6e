/* The Bellman-row kernels of lpbounds other than the row sweeps of exact DP (rowsweeps.c),
 * compiled ahead of time: Q-values, the game operator, row hashes, the post-decision
 * form's passes and sweeps, reward codes, and the aggregation of rows (RLP's f-bar rows).
 *
 * Every function that loops over owners, rows, states, buckets or groups works on one
 * range [start, end) of them and releases the GIL, so that lpbounds._kernels.ckernels runs
 * one range per thread; bucket_order and reward_codes are serial (their result depends on
 * the order of the whole pass). The arithmetic is that of the numpy twins
 * (lpbounds._kernels.twins), term by term: a row reads
 *
 *     acc = 0.0;  acc += probs[r, l] * v[targets[r, l]]   for l = 0 .. L-1, in order;
 *     q_r = reward[r] + discount * acc
 *
 * with no fused multiply-add (built with -ffp-contract=off, see setup.py) and no
 * reassociation, so every number is bit-identical to theirs (tests/test_ckernels.py). A
 * max (min) keeps the first row or action that attains it (strict comparisons), never a
 * NaN; the extremes of out - v are exact minima and maxima, whatever the ranges.
 *
 * Arrays come through the buffer protocol (no numpy headers at build time), C-contiguous
 * (probs may be any strided 2-D float64 view: a broadcast row, stride 0, when all rows
 * share one distribution). Every index read from an array is checked before it is used:
 * an index outside its array raises IndexError naming the argument and the entry, a
 * malformed offset array ValueError, a wrong dtype or shape TypeError / ValueError; no
 * input makes these functions read or write outside their buffers. Plain C99: no VLAs, no
 * compiler extensions (it builds with MSVC as well as gcc and clang).
 */
#include "buffers.h"

#define SHAPE(B, D) ((B).b.shape[D])
#define DATA(B) ((char *)(B).b.buf)

/* ------------------------------------------------------------------------------ errors */

/* The first bad entry a range met (set without the GIL, raised after). */
typedef struct {
    PyObject *type; /* NULL: none */
    const char *name;
    int nd;
    Py_ssize_t i[3];
    long long value, limit;
    const char *why; /* NULL: "is outside [0, limit)" */
} Bad;

static int bad(Bad *e, PyObject *type, const char *name, int nd, Py_ssize_t i0, Py_ssize_t i1,
               Py_ssize_t i2, long long value, long long limit, const char *why) {
    e->type = type;
    e->name = name;
    e->nd = nd;
    e->i[0] = i0;
    e->i[1] = i1;
    e->i[2] = i2;
    e->value = value;
    e->limit = limit;
    e->why = why;
    return -1;
}

#define BAD_INDEX(E, NAME, ND, I0, I1, I2, VALUE, LIMIT)                                  \
    bad(E, PyExc_IndexError, NAME, ND, I0, I1, I2, (long long)(VALUE), (long long)(LIMIT), NULL)

static PyObject *raise_bad(const Bad *e) {
    if (e->why == NULL) {
        if (e->nd == 1)
            PyErr_Format(e->type, "%s[%zd] = %lld is outside [0, %lld)", e->name, e->i[0],
                         e->value, e->limit);
        else if (e->nd == 2)
            PyErr_Format(e->type, "%s[%zd, %zd] = %lld is outside [0, %lld)", e->name, e->i[0],
                         e->i[1], e->value, e->limit);
        else
            PyErr_Format(e->type, "%s[%zd, %zd, %zd] = %lld is outside [0, %lld)", e->name,
                         e->i[0], e->i[1], e->i[2], e->value, e->limit);
    } else if (e->nd == 1) {
        PyErr_Format(e->type, "%s[%zd] = %lld %s", e->name, e->i[0], e->value, e->why);
    } else {
        PyErr_Format(e->type, "%s[%zd, %zd] = %lld %s", e->name, e->i[0], e->i[1], e->value,
                     e->why);
    }
    return NULL;
}

/* One call's buffers and the first bad entry its range met. */
typedef struct {
    Buf b[13];
    Bad e;
} Call;

static void call_init(Call *c) {
    memset(c, 0, sizeof *c);
    c->e.type = NULL;
}

/* The call's result: its buffers released; NULL with the bad entry raised if the range met
 * one (res is then dropped). */
static PyObject *call_end(Call *c, PyObject *res) {
    if (c->e.type) {
        Py_XDECREF(res);
        res = NULL;
        if (!PyErr_Occurred())
            raise_bad(&c->e);
    }
    release(c->b, (int)(sizeof c->b / sizeof c->b[0]));
    return res;
}

static PyObject *none(void) {
    Py_INCREF(Py_None);
    return Py_None;
}

/* ------------------------------------------------------------------------------ rows */

/* A row system as the row loops read it: reward (R,), targets (R, L) int32 / int64,
 * probs (R, L) at strides ps0, ps1, the values v (nv,). */
typedef struct {
    const double *reward;
    const char *targets;
    const char *probs;
    Py_ssize_t ps0, ps1, L, R;
    int t64;
    double lam;
    const double *v;
    Py_ssize_t nv;
} Rows;

static int get_rows(PyObject *reward, PyObject *targets, PyObject *probs, PyObject *v, double lam,
                    Buf *b, Rows *rw) {
    if (get(reward, &b[0], "reward", 1, 'f', 8, 0, 0) ||
        get(targets, &b[1], "targets", 2, 'i', S_IDX, 0, 0) ||
        get(probs, &b[2], "probs", 2, 'f', 8, 0, 1) || get(v, &b[3], "v", 1, 'f', 8, 0, 0))
        return -1;
    Py_ssize_t R = SHAPE(b[0], 0);
    if (need(SHAPE(b[1], 0) == R && SHAPE(b[2], 0) == R && SHAPE(b[2], 1) == SHAPE(b[1], 1),
             "reward, targets and probs: rows differ"))
        return -1;
    rw->reward = (const double *)b[0].b.buf;
    rw->targets = DATA(b[1]);
    rw->probs = DATA(b[2]);
    rw->ps0 = b[2].b.strides[0];
    rw->ps1 = b[2].b.strides[1];
    rw->L = SHAPE(b[1], 1);
    rw->R = R;
    rw->t64 = b[1].b.itemsize == 8;
    rw->lam = lam;
    rw->v = (const double *)b[3].b.buf;
    rw->nv = SHAPE(b[3], 0);
    return 0;
}

/* q = q_r(v) for targets of type TT; -1 (and *e) on a target outside v */
#define DEF_Q_ROW(SUF, TT)                                                                 \
    Py_LOCAL_INLINE(int) q_row_##SUF(const Rows *rw, Py_ssize_t r, double *q, Bad *e) {    \
        const TT *t = (const TT *)rw->targets + (size_t)r * (size_t)rw->L;                 \
        const char *p = rw->probs + r * rw->ps0;                                           \
        double acc = 0.0;                                                                  \
        for (Py_ssize_t l = 0; l < rw->L; l++) {                                           \
            int64_t k = (int64_t)t[l];                                                     \
            if ((uint64_t)k >= (uint64_t)rw->nv)                                           \
                return BAD_INDEX(e, "targets", 2, r, l, 0, k, rw->nv);                     \
            acc += *(const double *)(p + l * rw->ps1) * rw->v[k];                          \
        }                                                                                  \
        *q = rw->reward[r] + rw->lam * acc;                                                \
        return 0;                                                                          \
    }
DEF_Q_ROW(i32, int32_t)
DEF_Q_ROW(i64, int64_t)

#define Q_ROW(RW, R, Q, E) ((RW)->t64 ? q_row_i64(RW, R, Q, E) : q_row_i32(RW, R, Q, E))

static int q_range(const Rows *rw, double *out, Py_ssize_t start, Py_ssize_t end, Bad *e) {
    for (Py_ssize_t r = start; r < end; r++)
        if (Q_ROW(rw, r, &out[r], e))
            return -1;
    return 0;
}

PyDoc_STRVAR(q_values_doc,
             "q_values(reward, targets, probs, discount, v, out, start, end)\n\n"
             "out[r] = reward[r] + discount * sum_l probs[r, l] v[targets[r, l]] for rows "
             "start <= r < end. Releases the GIL.");

static PyObject *q_values(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_rew, *o_t, *o_p, *o_v, *o_out;
    double lam;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOdOOnn", &o_rew, &o_t, &o_p, &lam, &o_v, &o_out, &start, &end))
        return NULL;
    Call c;
    call_init(&c);
    Rows rw;
    if (get_rows(o_rew, o_t, o_p, o_v, lam, c.b, &rw) ||
        get(o_out, &c.b[4], "out", 1, 'f', 8, 1, 0) ||
        need(SHAPE(c.b[4], 0) == rw.R, "out needs one entry per row") ||
        check_range(start, end, rw.R))
        return call_end(&c, NULL);
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = q_range(&rw, (double *)c.b[4].b.buf, start, end, &c.e);
    Py_END_ALLOW_THREADS
    return call_end(&c, failed ? NULL : none());
}

#define INDPTR_WHY "is not an offset of rows: indptr must be non-decreasing within [0, rows]"

/* owners [start, end): the game operator (see bellman_maxmin_doc) */
static int maxmin_range(const Rows *rw, const int64_t *indptr, const int32_t *action,
                        double *out, int64_t *arg, Py_ssize_t start, Py_ssize_t end, Bad *e) {
    for (Py_ssize_t i = start; i < end; i++) {
        int64_t r = indptr[i], stop = indptr[i + 1];
        if (r < 0)
            return bad(e, PyExc_ValueError, "indptr", 1, i, 0, 0, r, 0, INDPTR_WHY);
        if (stop < r || stop > rw->R)
            return bad(e, PyExc_ValueError, "indptr", 1, i + 1, 0, 0, stop, 0, INDPTR_WHY);
        double best = -INFINITY;
        int64_t best_r = -1;
        while (r < stop) {
            int32_t a = action[r];
            double low = INFINITY;
            int64_t low_r = r;
            while (r < stop && action[r] == a) {
                double q;
                if (Q_ROW(rw, (Py_ssize_t)r, &q, e))
                    return -1;
                if (q < low) {
                    low = q;
                    low_r = r;
                }
                r++;
            }
            if (low > best) {
                best = low;
                best_r = low_r;
            }
        }
        out[i] = best;
        arg[i] = best_r;
    }
    return 0;
}

PyDoc_STRVAR(bellman_maxmin_doc,
             "bellman_maxmin(indptr, action, reward, targets, probs, discount, v, out, arg, "
             "start, end)\n\nThe stochastic-game operator for owners start <= i < end: "
             "out[i] = max over the actions of owner i's rows (sorted by action) of the min of "
             "q_r over that action's rows; arg[i] the minimising row of the first maximising "
             "action. Releases the GIL.");

static PyObject *bellman_maxmin(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_ip, *o_act, *o_rew, *o_t, *o_p, *o_v, *o_out, *o_arg;
    double lam;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOOOdOOOnn", &o_ip, &o_act, &o_rew, &o_t, &o_p, &lam, &o_v,
                          &o_out, &o_arg, &start, &end))
        return NULL;
    Call c;
    call_init(&c);
    Rows rw;
    if (get_rows(o_rew, o_t, o_p, o_v, lam, c.b, &rw) ||
        get(o_ip, &c.b[4], "indptr", 1, 'i', 8, 0, 0) ||
        get(o_act, &c.b[5], "action", 1, 'i', 4, 0, 0) ||
        get(o_out, &c.b[6], "out", 1, 'f', 8, 1, 0) ||
        get(o_arg, &c.b[7], "arg", 1, 'i', 8, 1, 0))
        return call_end(&c, NULL);
    Py_ssize_t n = SHAPE(c.b[4], 0) - 1;
    if (need(n >= 0, "indptr: empty (it has one entry more than the owners)") ||
        need(SHAPE(c.b[5], 0) == rw.R, "action needs one entry per row") ||
        need(SHAPE(c.b[6], 0) >= n && SHAPE(c.b[7], 0) >= n,
             "out and arg need one entry per owner") ||
        check_range(start, end, n))
        return call_end(&c, NULL);
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = maxmin_range(&rw, (const int64_t *)c.b[4].b.buf, (const int32_t *)c.b[5].b.buf,
                          (double *)c.b[6].b.buf, (int64_t *)c.b[7].b.buf, start, end, &c.e);
    Py_END_ALLOW_THREADS
    return call_end(&c, failed ? NULL : none());
}

/* ------------------------------------------------------------------------------ hashes */

#define MULT 0x9E3779B97F4A7C15ULL
#define SEED 0x2545F4914F6CDD1DULL

/* rows [start, end) of b = owner, action, targets, probbits, out; GET(B, I) the entry I of
 * owner (B = 0), action (1) or targets (2) */
#define HASH_LOOP(GET)                                                                     \
    for (Py_ssize_t r = start; r < end; r++) {                                             \
        uint64_t h = SEED;                                                                 \
        h = (h ^ (uint64_t)GET(0, r)) * MULT;                                              \
        h ^= h >> 31;                                                                      \
        h = (h ^ (uint64_t)GET(1, r)) * MULT;                                              \
        h ^= h >> 29;                                                                      \
        for (Py_ssize_t l = 0; l < L; l++) {                                               \
            h = (h ^ (uint64_t)GET(2, r * L + l)) * MULT;                                  \
            h ^= h >> 32;                                                                  \
            h = (h ^ pb[r * L + l]) * MULT;                                                \
            h ^= h >> 27;                                                                  \
        }                                                                                  \
        out[r] = h;                                                                        \
    }
#define GET_ANY(B, I) LD(x[B], I)
#define GET_I32(B, I) (int64_t)((const int32_t *)x[B].p)[I]
#define GET_I64(B, I) ((const int64_t *)x[B].p)[I]

static void hash_range(const Buf *b, Py_ssize_t start, Py_ssize_t end) {
    Py_ssize_t L = SHAPE(b[2], 1);
    Ix x[3];
    int size = 0; /* 4 or 8 when owner, action and targets are all int32 or all int64 */
    for (int k = 0; k < 3; k++) {
        x[k] = ix(&b[k]);
        int s_ = x[k].sgn && (x[k].size == 4 || x[k].size == 8) ? (int)x[k].size : -1;
        size = k == 0 ? s_ : (size == s_ ? size : -1);
    }
    const uint64_t *pb = (const uint64_t *)b[3].b.buf;
    uint64_t *out = (uint64_t *)b[4].b.buf;
    if (size == 4) {
        HASH_LOOP(GET_I32)
    } else if (size == 8) {
        HASH_LOOP(GET_I64)
    } else {
        HASH_LOOP(GET_ANY)
    }
}

PyDoc_STRVAR(hash_rows_doc,
             "hash_rows(owner, action, targets, probbits, out, start, end)\n\n"
             "A 64-bit hash of (owner, action, targets, probabilities' bits) for rows "
             "start <= r < end, into out (uint64). Releases the GIL.");

static PyObject *hash_rows(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_own, *o_act, *o_t, *o_pb, *o_out;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOOOnn", &o_own, &o_act, &o_t, &o_pb, &o_out, &start, &end))
        return NULL;
    Call c;
    call_init(&c);
    Buf *b = c.b;
    if (get(o_own, &b[0], "owner", 1, 'n', S_ANY, 0, 0) ||
        get(o_act, &b[1], "action", 1, 'n', S_ANY, 0, 0) ||
        get(o_t, &b[2], "targets", 2, 'n', S_ANY, 0, 0) ||
        get(o_pb, &b[3], "probbits", 2, 'n', 8, 0, 0) ||
        get(o_out, &b[4], "out", 1, 'u', 8, 1, 0))
        return call_end(&c, NULL);
    Py_ssize_t R = SHAPE(b[0], 0);
    if (need(SHAPE(b[1], 0) == R && SHAPE(b[2], 0) == R && SHAPE(b[3], 0) == R &&
                 SHAPE(b[3], 1) == SHAPE(b[2], 1) && SHAPE(b[4], 0) == R,
             "owner, action, targets, probbits and out: rows differ") ||
        check_range(start, end, R))
        return call_end(&c, NULL);
    Py_BEGIN_ALLOW_THREADS
    hash_range(b, start, end);
    Py_END_ALLOW_THREADS
    return call_end(&c, none());
}

/* ------------------------------------------------------------------------------ post-decision */

/* succ (n, A, L) and allowed (n, A) into b[0], b[1]: the pair (x, a) has its successors at
 * (x A + a) L */
static int get_pairs(PyObject *o_succ, PyObject *o_allowed, Buf *b) {
    if (get(o_succ, &b[0], "succ", 3, 'i', S_IDX, 0, 0) ||
        get(o_allowed, &b[1], "allowed", 2, 'b', 1, 0, 0))
        return -1;
    return need(SHAPE(b[1], 0) == SHAPE(b[0], 0) && SHAPE(b[1], 1) == SHAPE(b[0], 1),
                "succ and allowed: shapes differ (n, A, L) and (n, A)");
}

/* states [start, end) of succ (of type TS), allowed, seen */
#define MARK_LOOP(TS)                                                                      \
    for (Py_ssize_t x = start; x < end; x++)                                               \
        for (Py_ssize_t a = 0; a < A; a++)                                                 \
            if (allowed[x * A + a]) {                                                      \
                int64_t y = (int64_t)((const TS *)succ)[(x * A + a) * L];                  \
                if ((uint64_t)y >= (uint64_t)ns)                                           \
                    return BAD_INDEX(e, "succ", 3, x, a, 0, y, ns);                        \
                seen[y] = 1;                                                               \
            }

/* states [start, end) of b = succ, allowed, seen */
static int mark_range(const Buf *b, Py_ssize_t start, Py_ssize_t end, Bad *e) {
    Py_ssize_t A = SHAPE(b[0], 1), L = SHAPE(b[0], 2), ns = SHAPE(b[2], 0);
    const char *allowed = DATA(b[1]), *succ = DATA(b[0]);
    char *seen = DATA(b[2]);
    if (b[0].b.itemsize == 8) {
        MARK_LOOP(int64_t)
    } else {
        MARK_LOOP(int32_t)
    }
    return 0;
}

PyDoc_STRVAR(ps_mark_doc,
             "ps_mark(succ, allowed, seen, start, end)\n\nseen[succ[x, u, 0]] = True for "
             "every allowed pair of the states start <= x < end. Releases the GIL.");

static PyObject *ps_mark(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_s, *o_a, *o_seen;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOnn", &o_s, &o_a, &o_seen, &start, &end))
        return NULL;
    Call c;
    call_init(&c);
    if (get_pairs(o_s, o_a, c.b) || get(o_seen, &c.b[2], "seen", 1, 'b', 1, 1, 0) ||
        check_range(start, end, SHAPE(c.b[0], 0)))
        return call_end(&c, NULL);
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = mark_range(c.b, start, end, &c.e);
    Py_END_ALLOW_THREADS
    return call_end(&c, failed ? NULL : none());
}

/* states [start, end) of succ and outcomes (of type TS), allowed, post_id and first (of
 * type TI) */
#define FILL_LOOP(TS, TI)                                                                  \
    for (Py_ssize_t x = start; x < end; x++)                                               \
        for (Py_ssize_t a = 0; a < A; a++) {                                               \
            Py_ssize_t pair = x * A + a;                                                   \
            if (!allowed[pair]) {                                                          \
                ((TI *)first)[pair] = -1;                                                  \
                continue;                                                                  \
            }                                                                              \
            const TS *s_ = (const TS *)succ + pair * L;                                    \
            int64_t y = (int64_t)s_[0];                                                    \
            if ((uint64_t)y >= (uint64_t)npid)                                             \
                return BAD_INDEX(e, "succ", 3, x, a, 0, y, npid);                          \
            int64_t k = (int64_t)((const TI *)post_id)[y];                                 \
            if ((uint64_t)k >= (uint64_t)npost)                                            \
                return BAD_INDEX(e, "post_id", 1, (Py_ssize_t)y, 0, 0, k, npost);          \
            ((TI *)first)[pair] = (TI)k;                                                   \
            TS *o_ = (TS *)oc + k * L;                                                     \
            for (Py_ssize_t l = 0; l < L; l++)                                             \
                o_[l] = s_[l];                                                             \
        }

/* states [start, end) of b = succ, allowed, post_id, outcomes, first */
static int fill_range(const Buf *b, Py_ssize_t start, Py_ssize_t end, Bad *e) {
    Py_ssize_t A = SHAPE(b[0], 1), L = SHAPE(b[0], 2);
    Py_ssize_t npid = SHAPE(b[2], 0), npost = SHAPE(b[3], 0);
    const char *allowed = DATA(b[1]), *succ = DATA(b[0]), *post_id = DATA(b[2]);
    char *oc = DATA(b[3]), *first = DATA(b[4]);
    int s64 = b[0].b.itemsize == 8, i64 = b[2].b.itemsize == 8;
    if (s64 && i64) {
        FILL_LOOP(int64_t, int64_t)
    } else if (s64) {
        FILL_LOOP(int64_t, int32_t)
    } else if (i64) {
        FILL_LOOP(int32_t, int64_t)
    } else {
        FILL_LOOP(int32_t, int32_t)
    }
    return 0;
}

PyDoc_STRVAR(ps_fill_doc,
             "ps_fill(succ, allowed, post_id, outcomes, first, start, end)\n\nFor the states "
             "start <= x < end: first[x, u] = post_id[succ[x, u, 0]] (-1 if disallowed) and "
             "outcomes[first[x, u]] = succ[x, u]. Releases the GIL.");

static PyObject *ps_fill(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_s, *o_a, *o_pid, *o_oc, *o_first;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOOOnn", &o_s, &o_a, &o_pid, &o_oc, &o_first, &start, &end))
        return NULL;
    Call c;
    call_init(&c);
    Buf *b = c.b;
    if (get_pairs(o_s, o_a, b) || get(o_pid, &b[2], "post_id", 1, 'i', S_IDX, 0, 0) ||
        get(o_oc, &b[3], "outcomes", 2, 'i', (int)b[0].b.itemsize, 1, 0) ||
        get(o_first, &b[4], "first", 2, 'i', (int)b[2].b.itemsize, 1, 0))
        return call_end(&c, NULL);
    if (need(SHAPE(b[3], 1) == SHAPE(b[0], 2), "outcomes: one column per outcome of succ") ||
        need(SHAPE(b[4], 0) == SHAPE(b[0], 0) && SHAPE(b[4], 1) == SHAPE(b[0], 1),
             "first: shape (n, A) of succ") ||
        check_range(start, end, SHAPE(b[0], 0)))
        return call_end(&c, NULL);
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = fill_range(b, start, end, &c.e);
    Py_END_ALLOW_THREADS
    return call_end(&c, failed ? NULL : none());
}

/* states [start, end) of b = succ, first, outcomes: 1 if a tuple differs, 0, or -1 (*e) */
static int verify_range(const Buf *b, Py_ssize_t start, Py_ssize_t end, Bad *e) {
    Py_ssize_t A = SHAPE(b[0], 1), L = SHAPE(b[0], 2), isz = b[0].b.itemsize;
    Py_ssize_t npost = SHAPE(b[2], 0);
    const char *succ = DATA(b[0]), *oc = DATA(b[2]);
    Ix first = ix(&b[1]);
    for (Py_ssize_t x = start; x < end; x++)
        for (Py_ssize_t a = 0; a < A; a++) {
            int64_t k = LD(first, x * A + a);
            if (k < 0)
                continue;
            if (k >= npost)
                return BAD_INDEX(e, "first", 2, x, a, 0, k, npost);
            if (memcmp(oc + (size_t)(k * L * isz), succ + (size_t)((x * A + a) * L * isz),
                       (size_t)(L * isz)) != 0)
                return 1;
        }
    return 0;
}

PyDoc_STRVAR(ps_verify_doc,
             "ps_verify(succ, first, outcomes, start, end) -> int\n\n1 if an allowed pair "
             "(first >= 0) of the states start <= x < end has a tuple other than its "
             "outcomes row, else 0. Releases the GIL.");

static PyObject *ps_verify(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_s, *o_first, *o_oc;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOnn", &o_s, &o_first, &o_oc, &start, &end))
        return NULL;
    Call c;
    call_init(&c);
    Buf *b = c.b;
    if (get(o_s, &b[0], "succ", 3, 'i', S_IDX, 0, 0) ||
        get(o_first, &b[1], "first", 2, 'i', S_IDX, 0, 0) ||
        get(o_oc, &b[2], "outcomes", 2, 'i', (int)b[0].b.itemsize, 0, 0))
        return call_end(&c, NULL);
    if (need(SHAPE(b[1], 0) == SHAPE(b[0], 0) && SHAPE(b[1], 1) == SHAPE(b[0], 1),
             "first: shape (n, A) of succ") ||
        need(SHAPE(b[2], 1) == SHAPE(b[0], 2), "outcomes: one column per outcome of succ") ||
        check_range(start, end, SHAPE(b[0], 0)))
        return call_end(&c, NULL);
    int differ;
    Py_BEGIN_ALLOW_THREADS
    differ = verify_range(b, start, end, &c.e);
    Py_END_ALLOW_THREADS
    return call_end(&c, differ < 0 ? NULL : PyLong_FromLong(differ));
}

/* rows [start, end) of outcomes of type TT, LL outcomes (a constant or L) */
#define EXPECT_LOOP(TT, LL)                                                                \
    for (Py_ssize_t k = start; k < end; k++) {                                             \
        const TT *o_ = (const TT *)oc + (size_t)k * (LL);                                  \
        double acc = 0.0;                                                                  \
        for (Py_ssize_t l = 0; l < (LL); l++) {                                            \
            int64_t y = (int64_t)o_[l];                                                    \
            if ((uint64_t)y >= (uint64_t)nv)                                               \
                return BAD_INDEX(e, "outcomes", 2, k, l, 0, y, nv);                        \
            acc += p[l] * v[y];                                                            \
        }                                                                                  \
        w[k] = acc;                                                                        \
    }

#define DEF_EXPECT(SUF, TT)                                                                \
    static int expect_##SUF(const char *oc, Py_ssize_t L, const double *probs,             \
                            const double *v, Py_ssize_t nv, double *w, Py_ssize_t start,   \
                            Py_ssize_t end, Bad *e) {                                      \
        double pl[8]; /* up to 8 probabilities in locals: no store to w aliases them */    \
        const double *p = pl;                                                              \
        for (Py_ssize_t l = 0; l < L && l < 8; l++)                                        \
            pl[l] = probs[l];                                                              \
        switch (L) {                                                                       \
        case 1: EXPECT_LOOP(TT, 1) break;                                                  \
        case 2: EXPECT_LOOP(TT, 2) break;                                                  \
        case 3: EXPECT_LOOP(TT, 3) break;                                                  \
        case 4: EXPECT_LOOP(TT, 4) break;                                                  \
        case 5: EXPECT_LOOP(TT, 5) break;                                                  \
        case 6: EXPECT_LOOP(TT, 6) break;                                                  \
        case 7: EXPECT_LOOP(TT, 7) break;                                                  \
        case 8: EXPECT_LOOP(TT, 8) break;                                                  \
        default:                                                                           \
            p = probs;                                                                     \
            EXPECT_LOOP(TT, L) break;                                                      \
        }                                                                                  \
        return 0;                                                                          \
    }
DEF_EXPECT(i32, int32_t)
DEF_EXPECT(i64, int64_t)

PyDoc_STRVAR(ps_expect_doc,
             "ps_expect(outcomes, probs, v, w, start, end)\n\nw[k] = sum_l probs[l] "
             "v[outcomes[k, l]] (summed in outcome order from 0.0) for start <= k < end. "
             "Releases the GIL.");

static PyObject *ps_expect(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_oc, *o_p, *o_v, *o_w;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOOnn", &o_oc, &o_p, &o_v, &o_w, &start, &end))
        return NULL;
    Call c;
    call_init(&c);
    Buf *b = c.b;
    if (get(o_oc, &b[0], "outcomes", 2, 'i', S_IDX, 0, 0) ||
        get(o_p, &b[1], "probs", 1, 'f', 8, 0, 0) || get(o_v, &b[2], "v", 1, 'f', 8, 0, 0) ||
        get(o_w, &b[3], "w", 1, 'f', 8, 1, 0))
        return call_end(&c, NULL);
    Py_ssize_t npost = SHAPE(b[0], 0), L = SHAPE(b[0], 1);
    if (need(SHAPE(b[1], 0) == L, "probs: one probability per column of outcomes") ||
        need(SHAPE(b[3], 0) == npost, "w: one entry per row of outcomes") ||
        check_range(start, end, npost))
        return call_end(&c, NULL);
    int failed;
    const char *oc = DATA(b[0]);
    const double *p = (const double *)b[1].b.buf, *v = (const double *)b[2].b.buf;
    double *w = (double *)b[3].b.buf;
    Py_ssize_t nv = SHAPE(b[2], 0);
    Py_BEGIN_ALLOW_THREADS
    failed = b[0].b.itemsize == 8 ? expect_i64(oc, L, p, v, nv, w, start, end, &c.e)
                                  : expect_i32(oc, L, p, v, nv, w, start, end, &c.e);
    Py_END_ALLOW_THREADS
    return call_end(&c, failed ? NULL : none());
}

/* The post-decision sweeps' data: first (n, A) int32 / int64, the rewards either plain
 * (reward (n, A) float64) or coded (codes (n, A) uint8 / uint16 / uint32 into table),
 * w (nw,), v and out (n,), arg or act (n,) any integer type. */
typedef struct {
    const char *first;
    Py_ssize_t n, A;
    const double *reward;
    const char *codes;
    const double *table;
    Py_ssize_t ntable;
    const double *w;
    Py_ssize_t nw;
    double lam;
    const double *v;
    double *out;
    Ix arg; /* arg of the max sweep, act of the policy sweep */
} Post;

/* the sweep's data in locals (no store aliases them: arg may be int8), first of type TF,
 * codes of type TC */
#define POST_LOCALS(TF, TC)                                                                \
    const TF *first = (const TF *)ps->first;                                               \
    const Py_ssize_t A = ps->A, nw = ps->nw, ntable = ps->ntable;                          \
    const double *reward = ps->reward, *table = ps->table, *w = ps->w, *v = ps->v;         \
    const TC *codes = (const TC *)ps->codes;                                               \
    const double lam = ps->lam;                                                            \
    double *out = ps->out;                                                                 \
    const Ix arg = ps->arg;                                                                \
    double lc = INFINITY, hc = -INFINITY;                                                  \
    (void)reward;                                                                          \
    (void)table;                                                                           \
    (void)codes;                                                                           \
    (void)ntable

/* rew = the reward of pair (i, a): plain, or table[codes[i, a]] */
#define REW_PLAIN(I, A_, REW) (REW) = reward[(I) * A + (A_)]
#define REW_CODED(I, A_, REW)                                                              \
    do {                                                                                   \
        int64_t c_ = (int64_t)codes[(I) * A + (A_)];                                       \
        if (c_ >= ntable)                                                                  \
            return BAD_INDEX(e, "codes", 2, I, A_, 0, c_, ntable);                         \
        (REW) = table[c_];                                                                 \
    } while (0)

/* the extremes of out - v so far, lc and hc, with D */
#define EXTREMES(D)                                                                        \
    do {                                                                                   \
        if ((D) < lc)                                                                      \
            lc = (D);                                                                      \
        if ((D) > hc)                                                                      \
            hc = (D);                                                                      \
    } while (0)

/* states [start, end): out[i] = max_u reward(i, u) + lam w[first[i, u]], the first
 * maximising action into arg; extremes of out - v into *lo, *hi */
#define DEF_PS_MAX(SUF, TF, TC, REWARD)                                                    \
    static int ps_max_##SUF(const Post *ps, Py_ssize_t start, Py_ssize_t end, double *lo,  \
                            double *hi, Bad *e) {                                          \
        POST_LOCALS(TF, TC);                                                               \
        for (Py_ssize_t i = start; i < end; i++) {                                         \
            const TF *f = first + (size_t)i * (size_t)A;                                   \
            double best = -INFINITY;                                                       \
            int64_t best_a = -1;                                                           \
            for (Py_ssize_t a = 0; a < A; a++) {                                           \
                int64_t k = (int64_t)f[a];                                                 \
                if (k < 0)                                                                 \
                    continue;                                                              \
                if (k >= nw)                                                               \
                    return BAD_INDEX(e, "first", 2, i, a, 0, k, nw);                       \
                double rew;                                                                \
                REWARD(i, a, rew);                                                         \
                double q = rew + lam * w[k];                                               \
                if (q > best) {                                                            \
                    best = q;                                                              \
                    best_a = a;                                                            \
                }                                                                          \
            }                                                                              \
            out[i] = best;                                                                 \
            ST(arg, i, best_a);                                                            \
            EXTREMES(best - v[i]);                                                         \
        }                                                                                  \
        *lo = lc;                                                                          \
        *hi = hc;                                                                          \
        return 0;                                                                          \
    }

/* states [start, end): out[i] = reward(i, a) + lam w[first[i, a]] with a = act[i] (arg),
 * -inf where a = -1 */
#define DEF_PS_POLICY(SUF, TF, TC, REWARD)                                                 \
    static int ps_policy_##SUF(const Post *ps, Py_ssize_t start, Py_ssize_t end, double *lo, \
                               double *hi, Bad *e) {                                       \
        POST_LOCALS(TF, TC);                                                               \
        for (Py_ssize_t i = start; i < end; i++) {                                         \
            int64_t a = LD(arg, i);                                                        \
            if (a == -1) { /* no action (the max sweep's arg where none beats -inf) */     \
                out[i] = -INFINITY;                                                        \
                EXTREMES(-INFINITY - v[i]);                                                \
                continue;                                                                  \
            }                                                                              \
            if ((uint64_t)a >= (uint64_t)A)                                                \
                return BAD_INDEX(e, "act", 1, i, 0, 0, a, A);                              \
            int64_t k = (int64_t)first[i * A + a];                                         \
            if (k < 0)                                                                     \
                return bad(e, PyExc_IndexError, "act", 1, i, 0, 0, a, 0,                   \
                           "is not allowed at that state (first = -1)");                   \
            if (k >= nw)                                                                   \
                return BAD_INDEX(e, "first", 2, i, (Py_ssize_t)a, 0, k, nw);               \
            double rew;                                                                    \
            REWARD(i, a, rew);                                                             \
            double q = rew + lam * w[k];                                                   \
            out[i] = q;                                                                    \
            EXTREMES(q - v[i]);                                                            \
        }                                                                                  \
        *lo = lc;                                                                          \
        *hi = hc;                                                                          \
        return 0;                                                                          \
    }

#define DEF_PS_BOTH(SUF, TF, TC, REWARD)                                                   \
    DEF_PS_MAX(SUF, TF, TC, REWARD)                                                        \
    DEF_PS_POLICY(SUF, TF, TC, REWARD)
DEF_PS_BOTH(i32_f, int32_t, double, REW_PLAIN)
DEF_PS_BOTH(i64_f, int64_t, double, REW_PLAIN)
DEF_PS_BOTH(i32_u8, int32_t, uint8_t, REW_CODED)
DEF_PS_BOTH(i64_u8, int64_t, uint8_t, REW_CODED)
DEF_PS_BOTH(i32_u16, int32_t, uint16_t, REW_CODED)
DEF_PS_BOTH(i64_u16, int64_t, uint16_t, REW_CODED)
DEF_PS_BOTH(i32_u32, int32_t, uint32_t, REW_CODED)
DEF_PS_BOTH(i64_u32, int64_t, uint32_t, REW_CODED)

typedef int (*PostRange)(const Post *, Py_ssize_t, Py_ssize_t, double *, double *, Bad *);

/* the loop for first's and the codes' item sizes (code size 0: plain rewards) */
static PostRange post_range(int policy, Py_ssize_t first_size, Py_ssize_t code_size) {
    static const PostRange max_fns[2][4] = {
        {ps_max_i32_f, ps_max_i32_u8, ps_max_i32_u16, ps_max_i32_u32},
        {ps_max_i64_f, ps_max_i64_u8, ps_max_i64_u16, ps_max_i64_u32}};
    static const PostRange pol_fns[2][4] = {
        {ps_policy_i32_f, ps_policy_i32_u8, ps_policy_i32_u16, ps_policy_i32_u32},
        {ps_policy_i64_f, ps_policy_i64_u8, ps_policy_i64_u16, ps_policy_i64_u32}};
    int fi = first_size == 8;
    int ci = code_size == 0 ? 0 : code_size == 1 ? 1 : code_size == 2 ? 2 : 3;
    return policy ? pol_fns[fi][ci] : max_fns[fi][ci];
}

/* Parse and run one post-decision sweep: max (arg written) or policy (act read), plain or
 * coded rewards. The arguments, in order: first, [codes, table | reward], [act], w,
 * discount, v, out, [arg], start, end; o[] takes them as first, reward or codes, table,
 * act or arg, w, v, out. */
static PyObject *post_sweep(PyObject *args, int policy, int coded) {
    PyObject *o[7] = {NULL, NULL, NULL, NULL, NULL, NULL, NULL};
    double lam;
    Py_ssize_t start, end;
    int ok;
    if (coded && policy)
        ok = PyArg_ParseTuple(args, "OOOOOdOOnn", &o[0], &o[1], &o[2], &o[3], &o[4], &lam, &o[5],
                              &o[6], &start, &end);
    else if (coded)
        ok = PyArg_ParseTuple(args, "OOOOdOOOnn", &o[0], &o[1], &o[2], &o[4], &lam, &o[5], &o[6],
                              &o[3], &start, &end);
    else if (policy)
        ok = PyArg_ParseTuple(args, "OOOOdOOnn", &o[0], &o[1], &o[3], &o[4], &lam, &o[5], &o[6],
                              &start, &end);
    else
        ok = PyArg_ParseTuple(args, "OOOdOOOnn", &o[0], &o[1], &o[4], &lam, &o[5], &o[6], &o[3],
                              &start, &end);
    if (!ok)
        return NULL;
    Call c;
    call_init(&c);
    Buf *b = c.b;
    if (get(o[0], &b[0], "first", 2, 'i', S_IDX, 0, 0) ||
        (coded ? get(o[1], &b[1], "codes", 2, 'u', 1 | 2 | 4, 0, 0) ||
                     get(o[2], &b[2], "table", 1, 'f', 8, 0, 0)
               : get(o[1], &b[1], "reward", 2, 'f', 8, 0, 0)) ||
        get(o[3], &b[3], policy ? "act" : "arg", 1, 'n', S_ANY, !policy, 0) ||
        get(o[4], &b[4], "w", 1, 'f', 8, 0, 0) || get(o[5], &b[5], "v", 1, 'f', 8, 0, 0) ||
        get(o[6], &b[6], "out", 1, 'f', 8, 1, 0))
        return call_end(&c, NULL);
    Post ps;
    ps.n = SHAPE(b[0], 0);
    ps.A = SHAPE(b[0], 1);
    if (need(SHAPE(b[1], 0) == ps.n && SHAPE(b[1], 1) == ps.A,
             coded ? "codes: the shape (n, A) of first" : "reward: the shape (n, A) of first") ||
        need(SHAPE(b[3], 0) == ps.n && SHAPE(b[5], 0) == ps.n && SHAPE(b[6], 0) == ps.n,
             policy ? "act, v and out need one entry per state (row of first)"
                    : "arg, v and out need one entry per state (row of first)") ||
        check_range(start, end, ps.n))
        return call_end(&c, NULL);
    ps.first = DATA(b[0]);
    ps.reward = coded ? NULL : (const double *)b[1].b.buf;
    ps.codes = coded ? DATA(b[1]) : NULL;
    ps.table = coded ? (const double *)b[2].b.buf : NULL;
    ps.ntable = coded ? SHAPE(b[2], 0) : 0;
    ps.w = (const double *)b[4].b.buf;
    ps.nw = SHAPE(b[4], 0);
    ps.lam = lam;
    ps.v = (const double *)b[5].b.buf;
    ps.out = (double *)b[6].b.buf;
    ps.arg = ix(&b[3]);
    PostRange fn = post_range(policy, b[0].b.itemsize, coded ? b[1].b.itemsize : 0);
    double lo = INFINITY, hi = -INFINITY;
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = fn(&ps, start, end, &lo, &hi, &c.e);
    Py_END_ALLOW_THREADS
    return call_end(&c, failed ? NULL : Py_BuildValue("dd", lo, hi));
}

PyDoc_STRVAR(ps_max_stats_doc,
             "ps_max_stats(first, reward, w, discount, v, out, arg, start, end) -> (lo, hi)\n\n"
             "For states start <= x < end: out[x] = max_u reward[x, u] + discount "
             "w[first[x, u]] over the pairs with first >= 0, the first maximising action in arg "
             "(-1 if none); returns the min and max of out - v over the range. Releases the GIL.");
static PyObject *ps_max_stats(PyObject *Py_UNUSED(self), PyObject *args) {
    return post_sweep(args, 0, 0);
}

PyDoc_STRVAR(ps_policy_stats_doc,
             "ps_policy_stats(first, reward, act, w, discount, v, out, start, end) -> (lo, hi)\n\n"
             "For states start <= x < end: out[x] = reward[x, a] + discount w[first[x, a]] with "
             "a = act[x], -inf where act[x] = -1 (no action: ps_max_stats' arg where no action "
             "beats -inf); returns the min and max of out - v. IndexError for another action "
             "outside [0, A) or one not allowed (first = -1). Releases the GIL.");
static PyObject *ps_policy_stats(PyObject *Py_UNUSED(self), PyObject *args) {
    return post_sweep(args, 1, 0);
}

PyDoc_STRVAR(ps_max_stats_coded_doc,
             "ps_max_stats_coded(first, codes, table, w, discount, v, out, arg, start, end) -> "
             "(lo, hi)\n\nps_max_stats with rewards table[codes[x, u]].");
static PyObject *ps_max_stats_coded(PyObject *Py_UNUSED(self), PyObject *args) {
    return post_sweep(args, 0, 1);
}

PyDoc_STRVAR(ps_policy_stats_coded_doc,
             "ps_policy_stats_coded(first, codes, table, act, w, discount, v, out, start, end) "
             "-> (lo, hi)\n\nps_policy_stats with rewards table[codes[x, u]].");
static PyObject *ps_policy_stats_coded(PyObject *Py_UNUSED(self), PyObject *args) {
    return post_sweep(args, 1, 1);
}

/* states [start, end): out[x] = rs[x] + allowed actions below a = GET(x); -1 where a = -1 */
#define ROWS_LOOP(GET)                                                                     \
    for (Py_ssize_t x = start; x < end; x++) {                                             \
        int64_t a = GET(x);                                                                \
        if (a == -1) { /* no action: no row */                                             \
            out[x] = -1;                                                                   \
            continue;                                                                      \
        }                                                                                  \
        if ((uint64_t)a >= (uint64_t)A)                                                    \
            return BAD_INDEX(e, "act", 1, x, 0, 0, a, A);                                  \
        int64_t r = rs[x];                                                                 \
        for (int64_t u = 0; u < a; u++)                                                    \
            r += allowed[x * A + u] != 0;                                                  \
        out[x] = r;                                                                        \
    }
#define ACT_ANY(X) LD(act, X)
#define ACT_I8(X) (int64_t)((const int8_t *)act.p)[X]
#define ACT_I64(X) ((const int64_t *)act.p)[X]

/* states [start, end) of b = allowed, row_start, act, out */
static int rows_range(const Buf *b, Py_ssize_t start, Py_ssize_t end, Bad *e) {
    Py_ssize_t A = SHAPE(b[0], 1);
    const char *allowed = DATA(b[0]);
    const int64_t *rs = (const int64_t *)b[1].b.buf;
    int64_t *out = (int64_t *)b[3].b.buf;
    Ix act = ix(&b[2]);
    if (act.sgn && act.size == 1) { /* the int8 actions of PostDecisionRows.new_arg */
        ROWS_LOOP(ACT_I8)
    } else if (act.sgn && act.size == 8) {
        ROWS_LOOP(ACT_I64)
    } else {
        ROWS_LOOP(ACT_ANY)
    }
    return 0;
}

PyDoc_STRVAR(ps_rows_doc,
             "ps_rows(allowed, row_start, act, out, start, end)\n\nFor states start <= x < end: "
             "out[x] = row_start[x] + the number of allowed actions below act[x] (the row of "
             "the pair (x, act[x]) in BellmanRows.from_mdp), -1 where act[x] = -1 (no action). "
             "Releases the GIL.");

static PyObject *ps_rows(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_a, *o_rs, *o_act, *o_out;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOOnn", &o_a, &o_rs, &o_act, &o_out, &start, &end))
        return NULL;
    Call c;
    call_init(&c);
    Buf *b = c.b;
    if (get(o_a, &b[0], "allowed", 2, 'b', 1, 0, 0) ||
        get(o_rs, &b[1], "row_start", 1, 'i', 8, 0, 0) ||
        get(o_act, &b[2], "act", 1, 'n', S_ANY, 0, 0) ||
        get(o_out, &b[3], "out", 1, 'i', 8, 1, 0))
        return call_end(&c, NULL);
    Py_ssize_t n = SHAPE(b[0], 0);
    if (need(SHAPE(b[1], 0) == n && SHAPE(b[2], 0) == n && SHAPE(b[3], 0) == n,
             "row_start, act and out need one entry per state (row of allowed)") ||
        check_range(start, end, n))
        return call_end(&c, NULL);
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = rows_range(b, start, end, &c.e);
    Py_END_ALLOW_THREADS
    return call_end(&c, failed ? NULL : none());
}

/* The codes of the n rewards (see reward_codes_doc) with an open-addressing table of
 * ``size`` slots (a power of two) on the values' bits: keys, vals. */
static long long code_pass(const double *rew, Py_ssize_t n, long long max_codes, Ix codes,
                           double *table, int64_t *keys, int64_t *vals, long long size) {
    long long count = 0;
    uint64_t mask = (uint64_t)size - 1;
    for (long long j = 0; j < size; j++)
        vals[j] = -1;
    for (Py_ssize_t i = 0; i < n; i++) {
        int64_t key;
        memcpy(&key, &rew[i], sizeof key);
        uint64_t j = (((uint64_t)key * MULT) >> 40) & mask;
        while (vals[j] >= 0 && keys[j] != key)
            j = (j + 1) & mask;
        if (vals[j] < 0) {
            if (count >= max_codes)
                return -1;
            keys[j] = key;
            vals[j] = count;
            table[count] = rew[i];
            count++;
        }
        ST(codes, i, vals[j]);
    }
    return count;
}

PyDoc_STRVAR(reward_codes_doc,
             "reward_codes(reward, max_codes, codes, table) -> int\n\nDictionary-encode the "
             "2-D float64 reward: codes[x, u] numbers the distinct values (by their bits, so "
             "-0.0 and 0.0 differ) in order of first appearance, table[codes] == reward bit for "
             "bit. Returns the number of distinct values, or -1 as soon as there are more than "
             "max_codes (codes is then partly written). One serial pass; releases the GIL.");

static PyObject *reward_codes(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_rew, *o_codes, *o_table;
    long long max_codes;
    if (!PyArg_ParseTuple(args, "OLOO", &o_rew, &max_codes, &o_codes, &o_table))
        return NULL;
    Call c;
    call_init(&c);
    Buf *b = c.b;
    if (get(o_rew, &b[0], "reward", 2, 'f', 8, 0, 0) ||
        get(o_codes, &b[1], "codes", 2, 'u', 1 | 2 | 4, 1, 0) ||
        get(o_table, &b[2], "table", 1, 'f', 8, 1, 0))
        return call_end(&c, NULL);
    Py_ssize_t n = SHAPE(b[0], 0) * SHAPE(b[0], 1);
    long long most = max_codes < n ? max_codes : (long long)n; /* codes the pass can make */
    if (need(SHAPE(b[1], 0) == SHAPE(b[0], 0) && SHAPE(b[1], 1) == SHAPE(b[0], 1),
             "codes: the shape of reward") ||
        need(max_codes <= (1LL << (8 * b[1].b.itemsize)),
             "max_codes: more codes than the dtype of codes holds") ||
        need(most <= SHAPE(b[2], 0), "table: shorter than max_codes"))
        return call_end(&c, NULL);
    if (max_codes < 1)
        return call_end(&c, PyLong_FromLongLong(n == 0 ? 0 : -1));
    long long size = 1;
    while (size < 4 * most)
        size *= 2;
    int64_t *keys = PyMem_Malloc((size_t)size * sizeof(int64_t));
    int64_t *vals = PyMem_Malloc((size_t)size * sizeof(int64_t));
    if (keys == NULL || vals == NULL) {
        PyMem_Free(keys);
        PyMem_Free(vals);
        return call_end(&c, PyErr_NoMemory());
    }
    long long count;
    Py_BEGIN_ALLOW_THREADS
    count = code_pass((const double *)b[0].b.buf, n, max_codes, ix(&b[1]), (double *)b[2].b.buf,
                      keys, vals, size);
    Py_END_ALLOW_THREADS
    PyMem_Free(keys);
    PyMem_Free(vals);
    return call_end(&c, PyLong_FromLongLong(count));
}

/* ------------------------------------------------------------------------------ aggregation */

/* rows [start, end) of labels and out_t (of type TL), succ (of type TS): see
 * canonical_rows_doc; t, p: scratch rows of L entries */
#define CANONICAL_LOOP(TL, TS)                                                             \
    for (Py_ssize_t r = start; r < end; r++) {                                             \
        const TS *s_ = (const TS *)succ + r * L;                                           \
        TL *ot = (TL *)out_t + r * L;                                                      \
        double *orow = op + r * L;                                                         \
        for (Py_ssize_t l = 0; l < L; l++) {                                               \
            int64_t y = (int64_t)s_[l];                                                    \
            if ((uint64_t)y >= (uint64_t)nl)                                               \
                return BAD_INDEX(e, "succ", 2, r, l, 0, y, nl);                            \
            t[l] = (int64_t)((const TL *)labels)[y];                                       \
            p[l] = *(const double *)(probs + r * ps0 + l * ps1);                           \
        }                                                                                  \
        for (Py_ssize_t a = 1; a < L; a++) { /* stable insertion sort by target */         \
            int64_t tk = t[a];                                                             \
            double pk = p[a];                                                              \
            Py_ssize_t c = a - 1;                                                          \
            while (c >= 0 && t[c] > tk) {                                                  \
                t[c + 1] = t[c];                                                           \
                p[c + 1] = p[c];                                                           \
                c--;                                                                       \
            }                                                                              \
            t[c + 1] = tk;                                                                 \
            p[c + 1] = pk;                                                                 \
        }                                                                                  \
        Py_ssize_t k = 0;                                                                  \
        for (Py_ssize_t a = 0; a < L; a++) { /* merge equal targets, drop zeros */         \
            if (p[a] == 0.0)                                                               \
                continue;                                                                  \
            if (k > 0 && (int64_t)ot[k - 1] == t[a]) {                                     \
                orow[k - 1] += p[a];                                                       \
            } else {                                                                       \
                ot[k] = (TL)t[a];                                                          \
                orow[k] = p[a];                                                            \
                k++;                                                                       \
            }                                                                              \
        }                                                                                  \
        if (k == 0) {                                                                      \
            ot[0] = (TL)t[0];                                                              \
            orow[0] = 0.0;                                                                 \
            k = 1;                                                                         \
        }                                                                                  \
        for (Py_ssize_t a = k; a < L; a++) {                                               \
            ot[a] = ot[0];                                                                 \
            orow[a] = 0.0;                                                                 \
        }                                                                                  \
        int64_t x = LD(state, r);                                                          \
        if ((uint64_t)x >= (uint64_t)nl)                                                   \
            return BAD_INDEX(e, "state", 1, r, 0, 0, x, nl);                               \
        int64_t o = (int64_t)((const TL *)labels)[x];                                      \
        ((TL *)out_owner)[r] = (TL)o;                                                      \
        uint64_t h = SEED;                                                                 \
        for (Py_ssize_t a = 0; a < L; a++) {                                               \
            h = (h ^ (uint64_t)(int64_t)ot[a]) * MULT;                                     \
            h ^= h >> 32;                                                                  \
            h = (h ^ (uint64_t)(orow[a] * scale)) * MULT;                                  \
            h ^= h >> 29;                                                                  \
        }                                                                                  \
        oa[r] = o * n_actions + LD(action, r);                                             \
        okey[r] = h;                                                                       \
    }

/* rows [start, end) of b = labels, state, action, succ, probs, out_owner, out_t, out_p,
 * out_oa, out_key (see canonical_rows_doc); t, p: scratch rows of L entries */
static int canonical_range(const Buf *b, int64_t n_actions, Py_ssize_t start, Py_ssize_t end,
                           int64_t *t, double *p, Bad *e) {
    Py_ssize_t L = SHAPE(b[3], 1), nl = SHAPE(b[0], 0);
    Py_ssize_t ps0 = b[4].b.strides[0], ps1 = b[4].b.strides[1];
    const char *labels = DATA(b[0]), *succ = DATA(b[3]), *probs = DATA(b[4]);
    char *out_owner = DATA(b[5]), *out_t = DATA(b[6]);
    Ix state = ix(&b[1]), action = ix(&b[2]);
    double *op = (double *)b[7].b.buf;
    int64_t *oa = (int64_t *)b[8].b.buf;
    uint64_t *okey = (uint64_t *)b[9].b.buf;
    const double scale = 9007199254740992.0; /* 2**53: probabilities to integers for the hash */
    int l64 = b[0].b.itemsize == 8, s64 = b[3].b.itemsize == 8;
    if (l64 && s64) {
        CANONICAL_LOOP(int64_t, int64_t)
    } else if (l64) {
        CANONICAL_LOOP(int64_t, int32_t)
    } else if (s64) {
        CANONICAL_LOOP(int32_t, int64_t)
    } else {
        CANONICAL_LOOP(int32_t, int32_t)
    }
    return 0;
}

PyDoc_STRVAR(canonical_rows_doc,
             "canonical_rows(labels, state, action, succ, probs, n_actions, out_owner, out_t, "
             "out_p, out_oa, out_key, start, end)\n\nFor rows start <= r < end: the targets "
             "mapped to partitions (labels[succ[r]]) and stably sorted, equal targets merged "
             "(probabilities summed in sorted order), zero probabilities dropped, the row padded "
             "with its first target at probability 0; out_owner[r] = labels[state[r]], "
             "out_oa[r] = out_owner[r] * n_actions + action[r] and out_key[r] a 64-bit hash of "
             "the canonical row. Releases the GIL.");

static PyObject *canonical_rows(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o[10];
    long long n_actions;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOOOLOOOOOnn", &o[0], &o[1], &o[2], &o[3], &o[4], &n_actions,
                          &o[5], &o[6], &o[7], &o[8], &o[9], &start, &end))
        return NULL;
    Call c;
    call_init(&c);
    Buf *b = c.b;
    if (get(o[0], &b[0], "labels", 1, 'i', S_IDX, 0, 0) ||
        get(o[1], &b[1], "state", 1, 'i', S_IDX, 0, 0) ||
        get(o[2], &b[2], "action", 1, 'n', S_ANY, 0, 0) ||
        get(o[3], &b[3], "succ", 2, 'i', S_IDX, 0, 0) ||
        get(o[4], &b[4], "probs", 2, 'f', 8, 0, 1) ||
        get(o[5], &b[5], "out_owner", 1, 'i', (int)b[0].b.itemsize, 1, 0) ||
        get(o[6], &b[6], "out_t", 2, 'i', (int)b[0].b.itemsize, 1, 0) ||
        get(o[7], &b[7], "out_p", 2, 'f', 8, 1, 0) ||
        get(o[8], &b[8], "out_oa", 1, 'i', 8, 1, 0) ||
        get(o[9], &b[9], "out_key", 1, 'u', 8, 1, 0))
        return call_end(&c, NULL);
    Py_ssize_t R = SHAPE(b[3], 0), L = SHAPE(b[3], 1);
    if (need(L >= 1, "succ: rows need at least one outcome") ||
        need(SHAPE(b[1], 0) == R && SHAPE(b[2], 0) == R && SHAPE(b[5], 0) == R &&
                 SHAPE(b[8], 0) == R && SHAPE(b[9], 0) == R,
             "state, action, out_owner, out_oa and out_key need one entry per row of succ") ||
        need(SHAPE(b[4], 0) == R && SHAPE(b[4], 1) == L && SHAPE(b[6], 0) == R &&
                 SHAPE(b[6], 1) == L && SHAPE(b[7], 0) == R && SHAPE(b[7], 1) == L,
             "probs, out_t and out_p: the shape of succ") ||
        check_range(start, end, R))
        return call_end(&c, NULL);
    int64_t *t = PyMem_Malloc((size_t)L * sizeof(int64_t));
    double *p = PyMem_Malloc((size_t)L * sizeof(double));
    if (t == NULL || p == NULL) {
        PyMem_Free(t);
        PyMem_Free(p);
        return call_end(&c, PyErr_NoMemory());
    }
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = canonical_range(b, (int64_t)n_actions, start, end, t, p, &c.e);
    Py_END_ALLOW_THREADS
    PyMem_Free(t);
    PyMem_Free(p);
    return call_end(&c, failed ? NULL : none());
}

/* the stable counting sort of bucket_order_doc; off zeroed, nb + 1 entries */
static int bucket_pass(const int64_t *oa, Py_ssize_t n, int64_t *order, int64_t *off,
                       Py_ssize_t nb, Bad *e) {
    for (Py_ssize_t r = 0; r < n; r++) {
        if ((uint64_t)oa[r] >= (uint64_t)nb)
            return BAD_INDEX(e, "oa", 1, r, 0, 0, oa[r], nb);
        off[oa[r] + 1]++;
    }
    for (Py_ssize_t k = 0; k < nb; k++)
        off[k + 1] += off[k];
    /* off[k] moves on to the next free slot of bucket k, ending at the start of bucket
     * k + 1; shifted back after */
    for (Py_ssize_t r = 0; r < n; r++)
        order[off[oa[r]]++] = r;
    for (Py_ssize_t k = nb; k > 0; k--)
        off[k] = off[k - 1];
    off[0] = 0;
    return 0;
}

PyDoc_STRVAR(bucket_order_doc,
             "bucket_order(oa, order, offsets)\n\nStable counting sort of the rows by oa "
             "(values in [0, len(offsets) - 1)): order (int64, one per row) lists the rows by "
             "bucket, offsets (int64) the buckets' starts. One serial pass; releases the GIL.");

static PyObject *bucket_order(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_oa, *o_order, *o_off;
    if (!PyArg_ParseTuple(args, "OOO", &o_oa, &o_order, &o_off))
        return NULL;
    Call c;
    call_init(&c);
    Buf *b = c.b;
    if (get(o_oa, &b[0], "oa", 1, 'i', 8, 0, 0) || get(o_order, &b[1], "order", 1, 'i', 8, 1, 0) ||
        get(o_off, &b[2], "offsets", 1, 'i', 8, 1, 0))
        return call_end(&c, NULL);
    Py_ssize_t n = SHAPE(b[0], 0), nb = SHAPE(b[2], 0) - 1;
    if (need(SHAPE(b[1], 0) == n, "order: one entry per entry of oa") ||
        need(nb >= 0, "offsets: empty (it has one entry more than the buckets)"))
        return call_end(&c, NULL);
    int failed;
    int64_t *off = (int64_t *)b[2].b.buf;
    Py_BEGIN_ALLOW_THREADS
    memset(off, 0, (size_t)(nb + 1) * sizeof(int64_t));
    failed = bucket_pass((const int64_t *)b[0].b.buf, n, (int64_t *)b[1].b.buf, off, nb, &c.e);
    Py_END_ALLOW_THREADS
    return call_end(&c, failed ? NULL : none());
}

/* rows of a bucket with their keys, sorted by key, stably */
typedef struct {
    uint64_t key;
    int64_t row;
} Keyed;

/* merge runs [lo, mid) and [mid, hi) of a into b (the left run first on ties) */
static void merge(const Keyed *a, Keyed *b, Py_ssize_t lo, Py_ssize_t mid, Py_ssize_t hi) {
    Py_ssize_t i = lo, j = mid, k = lo;
    while (i < mid && j < hi)
        b[k++] = a[j].key < a[i].key ? a[j++] : a[i++];
    while (i < mid)
        b[k++] = a[i++];
    while (j < hi)
        b[k++] = a[j++];
}

/* a stable sort of a[0:n] by key (scratch: n entries); the result is in a */
static void sort_keyed(Keyed *a, Keyed *scratch, Py_ssize_t n) {
    const Py_ssize_t run = 16;
    for (Py_ssize_t lo = 0; lo < n; lo += run) { /* insertion sort of short runs */
        Py_ssize_t hi = lo + run < n ? lo + run : n;
        for (Py_ssize_t i = lo + 1; i < hi; i++) {
            Keyed x = a[i];
            Py_ssize_t j = i - 1;
            while (j >= lo && a[j].key > x.key) {
                a[j + 1] = a[j];
                j--;
            }
            a[j + 1] = x;
        }
    }
    Keyed *src = a, *dst = scratch;
    for (Py_ssize_t width = run; width < n; width *= 2) {
        for (Py_ssize_t lo = 0; lo < n; lo += 2 * width) {
            Py_ssize_t mid = lo + width < n ? lo + width : n;
            Py_ssize_t hi = lo + 2 * width < n ? lo + 2 * width : n;
            merge(src, dst, lo, mid, hi);
        }
        Keyed *tmp = src;
        src = dst;
        dst = tmp;
    }
    if (src != a)
        memcpy(a, src, (size_t)n * sizeof(Keyed));
}

#define OFFSETS_WHY                                                                        \
    "is not an offset into order: offsets must be non-decreasing within [0, len(order)]"

/* buckets [start, end) of order (n rows) by key (nk entries): see sort_buckets_doc */
static int sort_range(int64_t *order, Py_ssize_t n, const int64_t *off, const uint64_t *key,
                      Py_ssize_t nk, Py_ssize_t start, Py_ssize_t end, Bad *e) {
    Py_ssize_t most = 0;
    for (Py_ssize_t k = start; k < end; k++) {
        if (off[k] < 0)
            return bad(e, PyExc_ValueError, "offsets", 1, k, 0, 0, off[k], 0, OFFSETS_WHY);
        if (off[k + 1] < off[k] || off[k + 1] > n)
            return bad(e, PyExc_ValueError, "offsets", 1, k + 1, 0, 0, off[k + 1], 0, OFFSETS_WHY);
        if (off[k + 1] - off[k] > most)
            most = (Py_ssize_t)(off[k + 1] - off[k]);
    }
    if (most < 2)
        return 0;
    Keyed *buf = PyMem_RawMalloc(2 * (size_t)most * sizeof(Keyed));
    if (buf == NULL)
        return bad(e, PyExc_MemoryError, "offsets", 1, 0, 0, 0, most, 0,
                   "rows in the largest bucket: no memory to sort them");
    for (Py_ssize_t k = start; k < end; k++) {
        Py_ssize_t lo = (Py_ssize_t)off[k], m = (Py_ssize_t)(off[k + 1] - off[k]);
        if (m < 2)
            continue;
        for (Py_ssize_t i = 0; i < m; i++) {
            int64_t r = order[lo + i];
            if ((uint64_t)r >= (uint64_t)nk) {
                PyMem_RawFree(buf);
                return BAD_INDEX(e, "order", 1, lo + i, 0, 0, r, nk);
            }
            buf[i].key = key[r];
            buf[i].row = r;
        }
        sort_keyed(buf, buf + most, m);
        for (Py_ssize_t i = 0; i < m; i++)
            order[lo + i] = buf[i].row;
    }
    PyMem_RawFree(buf);
    return 0;
}

PyDoc_STRVAR(sort_buckets_doc,
             "sort_buckets(order, offsets, key, start, end)\n\nSort each bucket "
             "order[offsets[b]:offsets[b+1]] of start <= b < end by key[row], stably (rows "
             "with equal keys keep their order), in place. Releases the GIL.");

static PyObject *sort_buckets(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_order, *o_off, *o_key;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOnn", &o_order, &o_off, &o_key, &start, &end))
        return NULL;
    Call c;
    call_init(&c);
    Buf *b = c.b;
    if (get(o_order, &b[0], "order", 1, 'i', 8, 1, 0) ||
        get(o_off, &b[1], "offsets", 1, 'i', 8, 0, 0) || get(o_key, &b[2], "key", 1, 'u', 8, 0, 0))
        return call_end(&c, NULL);
    Py_ssize_t nb = SHAPE(b[1], 0) - 1;
    if (need(nb >= 0, "offsets: empty (it has one entry more than the buckets)") ||
        check_range(start, end, nb))
        return call_end(&c, NULL);
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = sort_range((int64_t *)b[0].b.buf, SHAPE(b[0], 0), (const int64_t *)b[1].b.buf,
                        (const uint64_t *)b[2].b.buf, SHAPE(b[2], 0), start, end, &c.e);
    Py_END_ALLOW_THREADS
    return call_end(&c, failed ? NULL : none());
}

/* sorted rows [start, end) of b = order, oa, key, t, pbits, new: 1 on a collision, 0, or
 * -1 (*e) */
static int groups_range(const Buf *b, Py_ssize_t start, Py_ssize_t end, Bad *e) {
    const int64_t *order = (const int64_t *)b[0].b.buf, *oa = (const int64_t *)b[1].b.buf;
    const uint64_t *key = (const uint64_t *)b[2].b.buf;
    const int64_t *pb = (const int64_t *)b[4].b.buf;
    const char *t = DATA(b[3]);
    Py_ssize_t R = SHAPE(b[1], 0), L = SHAPE(b[3], 1), isz = b[3].b.itemsize;
    char *new_ = DATA(b[5]);
    int collision = 0;
    for (Py_ssize_t i = start; i < end; i++) {
        int64_t a = order[i];
        if ((uint64_t)a >= (uint64_t)R)
            return BAD_INDEX(e, "order", 1, i, 0, 0, a, R);
        if (i == 0) {
            new_[i] = 1;
            continue;
        }
        int64_t c = order[i - 1];
        if ((uint64_t)c >= (uint64_t)R)
            return BAD_INDEX(e, "order", 1, i - 1, 0, 0, c, R);
        if (oa[a] != oa[c] || key[a] != key[c]) {
            new_[i] = 1;
            continue;
        }
        int same = memcmp(t + (size_t)(a * L * isz), t + (size_t)(c * L * isz),
                          (size_t)(L * isz)) == 0 &&
                   memcmp(pb + (size_t)(a * L), pb + (size_t)(c * L),
                          (size_t)L * sizeof(int64_t)) == 0;
        new_[i] = !same;
        if (!same)
            collision = 1;
    }
    return collision;
}

PyDoc_STRVAR(mark_groups_doc,
             "mark_groups(order, oa, key, t, pbits, new, start, end) -> bool\n\nFor sorted rows "
             "start <= i < end: new[i] = True where row order[i] starts a group (i = 0, another "
             "oa or key than row order[i-1], or other targets or probability bits). Returns True "
             "if two different rows share oa and key (a hash collision). Releases the GIL.");

static PyObject *mark_groups(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o_order, *o_oa, *o_key, *o_t, *o_pb, *o_new;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOOOOnn", &o_order, &o_oa, &o_key, &o_t, &o_pb, &o_new, &start,
                          &end))
        return NULL;
    Call c;
    call_init(&c);
    Buf *b = c.b;
    if (get(o_order, &b[0], "order", 1, 'i', 8, 0, 0) ||
        get(o_oa, &b[1], "oa", 1, 'i', 8, 0, 0) || get(o_key, &b[2], "key", 1, 'u', 8, 0, 0) ||
        get(o_t, &b[3], "t", 2, 'i', S_IDX, 0, 0) || get(o_pb, &b[4], "pbits", 2, 'i', 8, 0, 0) ||
        get(o_new, &b[5], "new", 1, 'b', 1, 1, 0))
        return call_end(&c, NULL);
    Py_ssize_t n = SHAPE(b[0], 0), R = SHAPE(b[1], 0);
    if (need(SHAPE(b[2], 0) == R && SHAPE(b[3], 0) == R && SHAPE(b[4], 0) == R &&
                 SHAPE(b[4], 1) == SHAPE(b[3], 1),
             "oa, key, t and pbits: rows differ") ||
        need(SHAPE(b[5], 0) >= n, "new: one entry per entry of order") ||
        check_range(start, end, n))
        return call_end(&c, NULL);
    int collision;
    Py_BEGIN_ALLOW_THREADS
    collision = groups_range(b, start, end, &c.e);
    Py_END_ALLOW_THREADS
    return call_end(&c, collision < 0 ? NULL : PyBool_FromLong(collision));
}

#define STARTS_WHY                                                                         \
    "does not start or end a group: starts must be increasing within [0, len(order)] (no "  \
    "group empty)"

/* groups [start, end) of b = order, starts, reward, owner, action, t, p, group, red, g_owner,
 * g_action, g_t, g_p (see merge_groups_doc) */
/* groups [start, end): GET(X, I) and PUT(X, I, V) read owner and t, write g_owner and g_t */
#define MERGE_LOOP(GET, PUT)                                                               \
    for (Py_ssize_t g = start; g < end; g++) {                                             \
        int64_t lo = starts[g], hi = starts[g + 1];                                        \
        if (lo < 0)                                                                        \
            return bad(e, PyExc_ValueError, "starts", 1, g, 0, 0, lo, 0, STARTS_WHY);      \
        if (hi <= lo || hi > n)                                                            \
            return bad(e, PyExc_ValueError, "starts", 1, g + 1, 0, 0, hi, 0, STARTS_WHY);  \
        int64_t first = order[lo];                                                         \
        if ((uint64_t)first >= (uint64_t)R)                                                \
            return BAD_INDEX(e, "order", 1, (Py_ssize_t)lo, 0, 0, first, R);               \
        double best = reward[first];                                                       \
        for (int64_t k = lo; k < hi; k++) { /* the first row attaining the extreme */      \
            int64_t r = order[k];                                                          \
            if ((uint64_t)r >= (uint64_t)R)                                                \
                return BAD_INDEX(e, "order", 1, (Py_ssize_t)k, 0, 0, r, R);                \
            group[r] = g;                                                                  \
            if (use_max ? reward[r] > best : reward[r] < best)                             \
                best = reward[r];                                                          \
        }                                                                                  \
        red[g] = best;                                                                     \
        PUT(g_owner, g, GET(owner, first));                                                \
        ST(g_action, g, LD(action, first));                                                \
        for (Py_ssize_t l = 0; l < L; l++) {                                               \
            PUT(g_t, g * L + l, GET(t, first * L + l));                                    \
            gp[g * L + l] = p[first * L + l];                                              \
        }                                                                                  \
    }
#define GET_32(X, I) ((const int32_t *)(X).p)[I]
#define PUT_32(X, I, V) ((int32_t *)(X).p)[I] = (V)
#define GET_64(X, I) ((const int64_t *)(X).p)[I]
#define PUT_64(X, I, V) ((int64_t *)(X).p)[I] = (V)

/* groups [start, end) of b = order, starts, reward, owner, action, t, p, group, red, g_owner,
 * g_action, g_t, g_p (see merge_groups_doc) */
static int merge_range(const Buf *b, int use_max, Py_ssize_t start, Py_ssize_t end, Bad *e) {
    const int64_t *order = (const int64_t *)b[0].b.buf, *starts = (const int64_t *)b[1].b.buf;
    const double *reward = (const double *)b[2].b.buf, *p = (const double *)b[6].b.buf;
    int64_t *group = (int64_t *)b[7].b.buf;
    double *red = (double *)b[8].b.buf, *gp = (double *)b[12].b.buf;
    Ix owner = ix(&b[3]), action = ix(&b[4]), t = ix(&b[5]);
    Ix g_owner = ix(&b[9]), g_action = ix(&b[10]), g_t = ix(&b[11]);
    Py_ssize_t n = SHAPE(b[0], 0), R = SHAPE(b[2], 0), L = SHAPE(b[5], 1);
    /* g_owner and g_t have the types of owner and t (merge_groups checks) */
    if (owner.size == 4 && t.size == 4) {
        MERGE_LOOP(GET_32, PUT_32)
    } else if (owner.size == 8 && t.size == 8) {
        MERGE_LOOP(GET_64, PUT_64)
    } else {
        MERGE_LOOP(LD, ST)
    }
    return 0;
}

PyDoc_STRVAR(merge_groups_doc,
             "merge_groups(order, starts, reward, use_max, owner, action, t, p, group, red, "
             "g_owner, g_action, g_t, g_p, start, end)\n\nFor groups start <= g < end (rows "
             "order[starts[g]:starts[g+1]], none empty): group[row] = g for each of its rows, "
             "red[g] the largest (use_max) or smallest reward of its rows (the first on ties), "
             "and the group's representative, its first row: g_owner, g_action, g_t, g_p. "
             "Releases the GIL.");

static PyObject *merge_groups(PyObject *Py_UNUSED(self), PyObject *args) {
    PyObject *o[13];
    int use_max;
    Py_ssize_t start, end;
    if (!PyArg_ParseTuple(args, "OOOpOOOOOOOOOOnn", &o[0], &o[1], &o[2], &use_max, &o[3], &o[4],
                          &o[5], &o[6], &o[7], &o[8], &o[9], &o[10], &o[11], &o[12], &start, &end))
        return NULL;
    Call c;
    call_init(&c);
    Buf *b = c.b;
    if (get(o[0], &b[0], "order", 1, 'i', 8, 0, 0) ||
        get(o[1], &b[1], "starts", 1, 'i', 8, 0, 0) ||
        get(o[2], &b[2], "reward", 1, 'f', 8, 0, 0) ||
        get(o[3], &b[3], "owner", 1, 'n', S_ANY, 0, 0) ||
        get(o[4], &b[4], "action", 1, 'n', S_ANY, 0, 0) ||
        get(o[5], &b[5], "t", 2, 'n', S_ANY, 0, 0) || get(o[6], &b[6], "p", 2, 'f', 8, 0, 0) ||
        get(o[7], &b[7], "group", 1, 'i', 8, 1, 0) || get(o[8], &b[8], "red", 1, 'f', 8, 1, 0) ||
        get(o[9], &b[9], "g_owner", 1, b[3].kind, (int)b[3].b.itemsize, 1, 0) ||
        get(o[10], &b[10], "g_action", 1, b[4].kind, (int)b[4].b.itemsize, 1, 0) ||
        get(o[11], &b[11], "g_t", 2, b[5].kind, (int)b[5].b.itemsize, 1, 0) ||
        get(o[12], &b[12], "g_p", 2, 'f', 8, 1, 0))
        return call_end(&c, NULL);
    Py_ssize_t R = SHAPE(b[2], 0), G = SHAPE(b[1], 0) - 1, L = SHAPE(b[5], 1);
    if (need(G >= 0, "starts: empty (it has one entry more than the groups)") ||
        need(SHAPE(b[3], 0) == R && SHAPE(b[4], 0) == R && SHAPE(b[5], 0) == R &&
                 SHAPE(b[6], 0) == R && SHAPE(b[6], 1) == L && SHAPE(b[7], 0) == R,
             "reward, owner, action, t, p and group: rows differ") ||
        need(SHAPE(b[8], 0) == G && SHAPE(b[9], 0) == G && SHAPE(b[10], 0) == G &&
                 SHAPE(b[11], 0) == G && SHAPE(b[11], 1) == L && SHAPE(b[12], 0) == G &&
                 SHAPE(b[12], 1) == L,
             "red, g_owner, g_action, g_t and g_p need one entry (row) per group") ||
        check_range(start, end, G))
        return call_end(&c, NULL);
    int failed;
    Py_BEGIN_ALLOW_THREADS
    failed = merge_range(b, use_max, start, end, &c.e);
    Py_END_ALLOW_THREADS
    return call_end(&c, failed ? NULL : none());
}

/* ------------------------------------------------------------------------------ module */

static PyMethodDef methods[] = {
    {"q_values", q_values, METH_VARARGS, q_values_doc},
    {"bellman_maxmin", bellman_maxmin, METH_VARARGS, bellman_maxmin_doc},
    {"hash_rows", hash_rows, METH_VARARGS, hash_rows_doc},
    {"ps_mark", ps_mark, METH_VARARGS, ps_mark_doc},
    {"ps_fill", ps_fill, METH_VARARGS, ps_fill_doc},
    {"ps_verify", ps_verify, METH_VARARGS, ps_verify_doc},
    {"ps_expect", ps_expect, METH_VARARGS, ps_expect_doc},
    {"ps_max_stats", ps_max_stats, METH_VARARGS, ps_max_stats_doc},
    {"ps_policy_stats", ps_policy_stats, METH_VARARGS, ps_policy_stats_doc},
    {"ps_max_stats_coded", ps_max_stats_coded, METH_VARARGS, ps_max_stats_coded_doc},
    {"ps_policy_stats_coded", ps_policy_stats_coded, METH_VARARGS, ps_policy_stats_coded_doc},
    {"ps_rows", ps_rows, METH_VARARGS, ps_rows_doc},
    {"reward_codes", reward_codes, METH_VARARGS, reward_codes_doc},
    {"canonical_rows", canonical_rows, METH_VARARGS, canonical_rows_doc},
    {"bucket_order", bucket_order, METH_VARARGS, bucket_order_doc},
    {"sort_buckets", sort_buckets, METH_VARARGS, sort_buckets_doc},
    {"mark_groups", mark_groups, METH_VARARGS, mark_groups_doc},
    {"merge_groups", merge_groups, METH_VARARGS, merge_groups_doc},
    {NULL, NULL, 0, NULL}};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "rowkernels",
    "The Bellman-row kernels of lpbounds (Q-values, the game operator, the post-decision form, "
    "the aggregation of rows), compiled ahead of time (see lpbounds._kernels.ckernels).",
    -1, methods, NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit_rowkernels(void) { return PyModule_Create(&module); }

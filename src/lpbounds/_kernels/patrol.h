/* What the patrol's two C extensions share (patrolsweeps.c, patrolmc.c): checked integer
 * arithmetic, the partition key index of lpbounds.patrol.partitions and the model's encoding
 * (lpbounds.patrol.model). Python, the floating-point rule and the arrays come from
 * buffers.h, which every C file of the kernels includes first.
 */
#ifndef LPBOUNDS_PATROL_H
#define LPBOUNDS_PATROL_H

#include "buffers.h"

/* Stations at most: a state index is an int64 and the alert pattern a 62-bit code. */
#define PATROL_MMAX 62

/* ------------------------------------------------------------------ integers */
/* a * b into *r; 0 if it overflows (a, b >= 0) */
Py_LOCAL_INLINE(int) mul_ok(int64_t a, int64_t b, int64_t *r) {
    if (a < 0 || b < 0 || (a > 0 && b > INT64_MAX / a))
        return 0;
    *r = a * b;
    return 1;
}

Py_LOCAL_INLINE(int) add_ok(int64_t a, int64_t b, int64_t *r) {
    if (a < 0 || b < 0 || a > INT64_MAX - b)
        return 0;
    *r = a + b;
    return 1;
}

/* Python's a % b (the sign of b), b > 0 */
Py_LOCAL_INLINE(int64_t) floor_mod(int64_t a, int64_t b) {
    int64_t r = a % b;
    return r < 0 ? r + b : r;
}

/* r**e into *r; 0 if it overflows (r >= 1, e >= 0) */
static int pow_ok(int64_t r, int64_t e, int64_t *out) {
    int64_t p = 1;
    for (int64_t i = 0; i < e; i++)
        if (!mul_ok(p, r, &p))
            return 0;
    *out = p;
    return 1;
}

/* ------------------------------------------------------------------ partitions */
/* :func:`lpbounds.patrol.partitions.partition_index` of one key (key_index_kernel):
 * ``acode`` the alert pattern, station 0 the most significant of m bits, ``tb`` the
 * largest delay. A loiter key (d >= 1) needs 0 <= station_pos[l] < m (the caller's check). */
Py_LOCAL_INLINE(int64_t) key_index(int64_t l, int64_t w, int64_t d, int64_t acode, int64_t tb,
                                   const int64_t *station_pos, int64_t n_nodes, int64_t big_d,
                                   int64_t gamma, int64_t tb_size, int64_t lb_size, int64_t m) {
    if (d == 0) {
        int64_t within = acode == 0 ? 0 : 1 + (acode - 1) * gamma + (tb - 1);
        return (2 * l + (w < 0 ? 1 : 0)) * tb_size + within;
    }
    int64_t k = station_pos[l];
    int64_t low = acode & (((int64_t)1 << (m - 1 - k)) - 1);
    int64_t high = acode >> (m - k);
    int64_t acode_l = (high << (m - 1 - k)) | low;
    int64_t within = acode_l == 0 ? 0 : 1 + (acode_l - 1) * gamma + (tb - 1);
    return 2 * n_nodes * tb_size + (k * big_d + d - 1) * lb_size + within;
}

/* ------------------------------------------------------------------ the model */
/* The encoding's sizes and tables (lpbounds.patrol.model.PatrolModel), checked. */
typedef struct {
    int64_t N, m, D, gamma, radix, rm, rm1, n_travel, n_states;
    int64_t tb_size, lb_size, n_partitions;
    const int64_t *station_pos; /* (N,) */
    const int64_t *stations;    /* (m,) */
    const int64_t *w_travel;    /* (m,) */
    const int64_t *w_loiter;    /* (m, m) */
} PModel;

/* The sizes from N, m, D, Gamma: 0, or -1 with a ValueError when they are out of range or
 * the state or partition count overflows an int64. */
static int pmodel_sizes(PModel *pm, int64_t N, int64_t m, int64_t D, int64_t gamma) {
    pm->N = N;
    pm->m = m;
    pm->D = D;
    pm->gamma = gamma;
    pm->radix = gamma + 1;
    if (N < 1 || D < 1 || gamma < 1 || m < 1 || m > PATROL_MMAX) {
        PyErr_Format(PyExc_ValueError,
                     "patrol sizes N = %lld, m = %lld, D = %lld, Gamma = %lld: need N, D, Gamma "
                     ">= 1 and 1 <= m <= %d",
                     (long long)N, (long long)m, (long long)D, (long long)gamma, PATROL_MMAX);
        return -1;
    }
    int64_t t, lt, lm;
    int ok = pow_ok(pm->radix, m, &pm->rm) && mul_ok(2 * N, pm->rm, &pm->n_travel);
    pm->rm1 = ok ? pm->rm / pm->radix : 0;
    ok = ok && mul_ok(m * D, pm->rm1, &t) && add_ok(pm->n_travel, t, &pm->n_states);
    ok = ok && mul_ok(((int64_t)1 << m) - 1, gamma, &t) && add_ok(t, 1, &pm->tb_size);
    ok = ok && mul_ok(((int64_t)1 << (m - 1)) - 1, gamma, &t) && add_ok(t, 1, &pm->lb_size);
    ok = ok && mul_ok(2 * N, pm->tb_size, &lt) && mul_ok(m * D, pm->lb_size, &lm) &&
         add_ok(lt, lm, &pm->n_partitions);
    if (!ok) {
        PyErr_SetString(PyExc_ValueError, "patrol sizes: the state count overflows an int64");
        return -1;
    }
    return 0;
}

/* station_pos (N,) and the stations (m,) agree: stations[k] is the node whose position
 * is k, every other node has -1. */
static int pmodel_stations(PModel *pm, const int64_t *station_pos, const int64_t *stations) {
    int64_t count = 0;
    for (int64_t l = 0; l < pm->N; l++) {
        int64_t k = station_pos[l];
        if (k < -1 || k >= pm->m || (k >= 0 && stations[k] != l)) {
            PyErr_Format(PyExc_ValueError,
                         "station_pos[%lld] = %lld is not the position of node %lld among the "
                         "%lld stations",
                         (long long)l, (long long)k, (long long)l, (long long)pm->m);
            return -1;
        }
        count += k >= 0;
    }
    if (count != pm->m) {
        PyErr_Format(PyExc_ValueError, "station_pos names %lld stations, expected %lld",
                     (long long)count, (long long)pm->m);
        return -1;
    }
    pm->station_pos = station_pos;
    pm->stations = stations;
    return 0;
}

/* The delay weights of the encoding: w_travel[j] = R^(m-1-j); w_loiter[k, j] the weight of
 * station j's delay in a loiter state at station k (0 for j = k). ``wl_stride``: the row
 * stride of w_loiter, in items. Checked entry by entry (ValueError naming ``name``). */
static int pmodel_weights(const PModel *pm, const int64_t *w_travel, const int64_t *w_loiter,
                          Py_ssize_t wl_stride, const char *name_t, const char *name_l) {
    int64_t m = pm->m, r = pm->radix;
    for (int64_t j = 0; j < m; j++) {
        int64_t want = 0;
        pow_ok(r, m - 1 - j, &want);
        if (w_travel[j] != want) {
            PyErr_Format(PyExc_ValueError, "%s[%lld] = %lld, expected %lld", name_t,
                         (long long)j, (long long)w_travel[j], (long long)want);
            return -1;
        }
    }
    for (int64_t k = 0; k < m; k++)
        for (int64_t j = 0; j < m; j++) {
            int64_t want = 0;
            if (j != k)
                pow_ok(r, m - 2 - (j < k ? j : j - 1), &want);
            int64_t got = w_loiter[k * wl_stride + j];
            if (got != want) {
                PyErr_Format(PyExc_ValueError, "%s[%lld, %lld] = %lld, expected %lld", name_l,
                             (long long)k, (long long)j, (long long)got, (long long)want);
                return -1;
            }
        }
    return 0;
}

/* decode_kernel on one state x (0 <= x < n_states): its l, w, d and delays. */
#define DECODE_ONE(pm, x, L, W, Dd, TAU)                                                  \
    do {                                                                                  \
        int64_t xi_ = (x);                                                                \
        if (xi_ < (pm)->n_travel) {                                                       \
            int64_t lw_ = xi_ / (pm)->rm, code_ = xi_ - lw_ * (pm)->rm;                   \
            L = lw_ / 2;                                                                  \
            W = 1 - 2 * (lw_ % 2);                                                        \
            Dd = 0;                                                                       \
            for (int64_t j_ = (pm)->m - 1; j_ >= 0; j_--) {                               \
                TAU(j_) = code_ % (pm)->radix;                                            \
                code_ /= (pm)->radix;                                                     \
            }                                                                             \
        } else {                                                                          \
            int64_t y_ = xi_ - (pm)->n_travel, kd_ = y_ / (pm)->rm1;                      \
            int64_t code_ = y_ - kd_ * (pm)->rm1, k_ = kd_ / (pm)->D;                     \
            Dd = kd_ % (pm)->D + 1;                                                       \
            L = (pm)->stations[k_];                                                       \
            W = 1;                                                                        \
            TAU(k_) = 0;                                                                  \
            for (int64_t q_ = (pm)->m - 2; q_ >= 0; q_--) {                               \
                int64_t j_ = q_ >= k_ ? q_ + 1 : q_;                                      \
                TAU(j_) = code_ % (pm)->radix;                                            \
                code_ /= (pm)->radix;                                                     \
            }                                                                             \
        }                                                                                 \
    } while (0)

/* successor_kernel on one decoded state (l, w, d, TAU(j)) under ``action`` into
 * OUT(0..m): the successor with no alert and with an alert at station j (OUT(j + 1)).
 * A loiter needs 0 <= station_pos[l] < m (the caller's check). */
#define SUCCESSORS_ONE(pm, l, w, d, TAU, action, OUT)                                     \
    do {                                                                                  \
        int64_t m_ = (pm)->m, idx0_;                                                      \
        if ((action) == 2) {                                                              \
            int64_t k_ = (pm)->station_pos[l];                                            \
            const int64_t *wl_ = (pm)->w_loiter + k_ * m_;                                \
            idx0_ = (pm)->n_travel + (k_ * (pm)->D + (d)) * (pm)->rm1;                    \
            for (int64_t j_ = 0; j_ < m_; j_++) {                                         \
                int64_t t_ = TAU(j_);                                                     \
                if (j_ != k_ && t_ > 0)                                                   \
                    idx0_ += (t_ + 1 < (pm)->gamma ? t_ + 1 : (pm)->gamma) * wl_[j_];     \
            }                                                                             \
            OUT(0) = idx0_;                                                               \
            for (int64_t j_ = 0; j_ < m_; j_++)                                           \
                OUT(j_ + 1) = (j_ != k_ && TAU(j_) == 0) ? idx0_ + wl_[j_] : idx0_;       \
        } else {                                                                          \
            int64_t u_ = (action) == 0 ? 1 : -1, w2_ = (w) * u_;                          \
            int64_t l2_ = floor_mod((l) + w2_, (pm)->N);                                  \
            idx0_ = (2 * l2_ + (w2_ < 0 ? 1 : 0)) * (pm)->rm;                             \
            for (int64_t j_ = 0; j_ < m_; j_++) {                                         \
                int64_t t_ = TAU(j_);                                                     \
                if (t_ > 0)                                                               \
                    idx0_ += (t_ + 1 < (pm)->gamma ? t_ + 1 : (pm)->gamma) *              \
                             (pm)->w_travel[j_];                                          \
            }                                                                             \
            OUT(0) = idx0_;                                                               \
            for (int64_t j_ = 0; j_ < m_; j_++)                                           \
                OUT(j_ + 1) = TAU(j_) == 0 ? idx0_ + (pm)->w_travel[j_] : idx0_;          \
        }                                                                                 \
    } while (0)

#endif

/* Arrays through the buffer protocol (no numpy headers at build time), for lpbounds' C
 * kernels: a typed argument check naming the argument (TypeError for the kind, ValueError
 * for the shape), items read whatever their width. C99, nothing compiler-specific.
 *
 * (rowsweeps.c has its own copy of the first of these, from before this header.)
 */
#ifndef LPBOUNDS_BUFFERS_H
#define LPBOUNDS_BUFFERS_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <stdint.h>

typedef struct {
    Py_buffer b;
    int held;
} PBuf;

/* 'f' float64, 'i' signed integer, 'b' bool, in native byte order; -1 for anything else */
Py_LOCAL_INLINE(int) pbuf_kind(const Py_buffer *b) {
    const char *f = b->format ? b->format : "B";
    const uint16_t one = 1;
    const char native_order = *(const char *)&one ? '<' : '>';
    while (*f == '@' || *f == '=' || *f == native_order)
        f++;
    if (f[0] == '\0' || f[1] != '\0')
        return -1;
    switch (f[0]) {
    case 'd':
        return b->itemsize == 8 ? 'f' : -1;
    case 'b': case 'h': case 'i': case 'l': case 'q': case 'n':
        return 'i';
    case '?':
        return 'b';
    default:
        return -1;
    }
}

/* Item sizes a signed-integer argument may have (a mask of these). */
#define SZ1 1
#define SZ2 2
#define SZ4 4
#define SZ8 8

/* ``o`` as a C-contiguous array of ``ndim`` dimensions, kind ``kind`` ('f', 'i', 'b') and
 * an item size in ``sizes`` (a mask of SZ*; ignored for 'f', always 8, and 'b', 1); a
 * TypeError naming the argument otherwise. */
static int pbuf_get(PyObject *o, PBuf *out, const char *name, int ndim, int kind, int sizes,
                    int writable) {
    int flags = PyBUF_FORMAT | PyBUF_STRIDES | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(o, &out->b, flags) < 0) {
        PyErr_Clear();
        PyErr_Format(PyExc_TypeError, "%s: expected a%s array", name,
                     writable ? " writable" : "");
        return -1;
    }
    out->held = 1;
    int k = pbuf_kind(&out->b);
    int size_ok = kind == 'i' ? (out->b.itemsize <= 8 && (out->b.itemsize & sizes) != 0)
                              : 1;
    if (k != kind || out->b.ndim != ndim || !size_ok) {
        const char *what = kind == 'f' ? "float64" : kind == 'b' ? "bool" : "integer";
        PyErr_Format(PyExc_TypeError, "%s: expected a %d-dimensional %s array%s", name, ndim,
                     what, kind == 'i' ? " of a supported width" : "");
        return -1;
    }
    Py_ssize_t s = out->b.itemsize;
    for (int d = ndim - 1; d >= 0; d--) {
        if (out->b.shape[d] > 1 && out->b.strides[d] != s) {
            PyErr_Format(PyExc_TypeError, "%s: not C-contiguous", name);
            return -1;
        }
        s *= out->b.shape[d];
    }
    return 0;
}

static void pbuf_release(PBuf *bs, int n) {
    for (int i = 0; i < n; i++)
        if (bs[i].held) {
            PyBuffer_Release(&bs[i].b);
            bs[i].held = 0;
        }
}

/* The i-th item of a signed-integer buffer, whatever its width. */
Py_LOCAL_INLINE(int64_t) pbuf_int(const PBuf *b, Py_ssize_t i) {
    switch (b->b.itemsize) {
    case 1:
        return ((const int8_t *)b->b.buf)[i];
    case 2:
        return ((const int16_t *)b->b.buf)[i];
    case 4:
        return ((const int32_t *)b->b.buf)[i];
    default:
        return ((const int64_t *)b->b.buf)[i];
    }
}

/* A ValueError naming the argument unless its shape is ``n0`` (and ``n1``; -1: any). */
static int pbuf_shape(const PBuf *b, const char *name, Py_ssize_t n0, Py_ssize_t n1) {
    if ((n0 >= 0 && b->b.shape[0] != n0) || (n1 >= 0 && b->b.ndim > 1 && b->b.shape[1] != n1)) {
        if (b->b.ndim > 1)
            PyErr_Format(PyExc_ValueError, "%s: shape (%zd, %zd), expected (%zd, %zd)", name,
                         b->b.shape[0], b->b.shape[1], n0 >= 0 ? n0 : b->b.shape[0],
                         n1 >= 0 ? n1 : b->b.shape[1]);
        else
            PyErr_Format(PyExc_ValueError, "%s: length %zd, expected %zd", name,
                         b->b.shape[0], n0);
        return -1;
    }
    return 0;
}

/* [start, end) within [0, n] */
static int range_ok(Py_ssize_t start, Py_ssize_t end, Py_ssize_t n, const char *what) {
    if (start < 0 || end < start || end > n) {
        PyErr_Format(PyExc_ValueError, "range [%zd, %zd) outside the %zd %s", start, end, n,
                     what);
        return -1;
    }
    return 0;
}

#endif

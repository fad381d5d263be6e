/* What every C file of lpbounds' kernels includes first (rowsweeps.c, rowkernels.c,
 * patrolsweeps.c, patrolmc.c): Python's header, the floating-point rule, and arrays
 * through the buffer protocol (no numpy headers at build time).
 *
 * Arrays: ``get`` takes an argument as a buffer of a given number of dimensions, kind and
 * item size, C-contiguous unless the caller reads it through its strides, and sets a
 * TypeError naming the argument otherwise (the kind, the dimensions, the item size, the
 * layout, or a read-only array where the kernel writes); ``check_shape`` and ``need`` set
 * a ValueError naming it when its shape disagrees; ``release`` lets them go; ``ld`` and
 * ``st`` read and write an integer item whatever its width. Kinds are numpy's letters:
 * 'f' float64, 'i' signed integer, 'u' unsigned integer, 'b' bool, and 'n' for an integer
 * of either sign; native byte order only.
 *
 * Floating point: no fused multiply-add anywhere, so that every sum is that of the numpy
 * twins, term by term, on every CPU. gcc and clang get -ffp-contract=off and MSVC
 * /fp:precise from setup.py; the pragma below says it to MSVC once more in the source.
 *
 * C99 with nothing compiler-specific (MSVC builds it as well as gcc and clang): no VLAs,
 * no GNU extensions or builtins; inline functions through Python's Py_LOCAL_INLINE.
 */
#ifndef LPBOUNDS_BUFFERS_H
#define LPBOUNDS_BUFFERS_H

#ifndef PY_SSIZE_T_CLEAN
#define PY_SSIZE_T_CLEAN
#endif
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#ifdef _MSC_VER
#pragma fp_contract(off)
#endif

/* Item sizes an integer argument may have: a mask of the sizes themselves (1 | 2 | 4 | 8).
 * 0 means S_IDX. */
#define S_ANY (1 | 2 | 4 | 8)
#define S_IDX (4 | 8) /* int32 or int64: an index array */

typedef struct {
    Py_buffer b;
    int held; /* b holds a buffer to release */
    int kind; /* 'f', 'i', 'u', 'b'; 0 for anything else */
} Buf;

/* The kind of a buffer's items ('f' float64, 'i' signed, 'u' unsigned, 'b' bool) in native
 * byte order; 0 for anything else. */
Py_LOCAL_INLINE(int) kind_of(const Py_buffer *b) {
    const char *f = b->format ? b->format : "B";
    const uint16_t one = 1;
    const char native_order = *(const char *)&one ? '<' : '>';
    while (*f == '@' || *f == '=' || *f == native_order)
        f++;
    if (f[0] == '\0' || f[1] != '\0')
        return 0;
    switch (f[0]) {
    case 'd':
        return b->itemsize == 8 ? 'f' : 0;
    case 'b': case 'h': case 'i': case 'l': case 'q': case 'n':
        return 'i';
    case 'B': case 'H': case 'I': case 'L': case 'Q': case 'N':
        return 'u';
    case '?':
        return b->itemsize == 1 ? 'b' : 0;
    default:
        return 0;
    }
}

Py_LOCAL_INLINE(const char *) kind_name(int kind) {
    switch (kind) {
    case 'f':
        return "float64";
    case 'b':
        return "bool";
    case 'u':
        return "unsigned integer";
    default:
        return "integer";
    }
}

/* ``o`` as a buffer of ``ndim`` dimensions and kind ``kind`` ('f', 'i', 'u', 'b', or 'n':
 * 'i' or 'u'), an integer's item size in the mask ``sizes`` (0: S_IDX; ignored for 'f' and
 * 'b', whose sizes are 8 and 1), writable if ``writable``, C-contiguous unless ``strided``
 * (the caller then reads it through its strides); 0, or -1 with a TypeError naming the
 * argument. ``out->held`` says whether ``out`` must be released, whatever the result. */
Py_LOCAL_INLINE(int) get(PyObject *o, Buf *out, const char *name, int ndim, int kind, int sizes,
               int writable, int strided) {
    int flags = PyBUF_FORMAT | PyBUF_STRIDES | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(o, &out->b, flags) < 0) {
        PyErr_Clear();
        PyErr_Format(PyExc_TypeError, "%s: expected a%s array", name,
                     writable ? " writable" : "");
        return -1;
    }
    out->held = 1;
    out->kind = kind_of(&out->b);
    Py_ssize_t isz = out->b.itemsize;
    int k = out->kind;
    int kind_ok = k != 0 && (k == kind || (kind == 'n' && (k == 'i' || k == 'u')));
    int mask = sizes ? sizes : S_IDX;
    int size_ok = k == 'f' || k == 'b' ||
                  ((isz == 1 || isz == 2 || isz == 4 || isz == 8) && (isz & mask));
    if (!kind_ok || out->b.ndim != ndim || !size_ok) {
        PyErr_Format(PyExc_TypeError,
                     "%s: expected a %d-dimensional %s array; got a %d-dimensional one of "
                     "format '%s', %zd bytes an item",
                     name, ndim, kind_name(kind), out->b.ndim,
                     out->b.format ? out->b.format : "B", isz);
        return -1;
    }
    if (!strided) {
        Py_ssize_t s = isz;
        for (int d = ndim - 1; d >= 0; d--) {
            if (out->b.shape[d] > 1 && out->b.strides[d] != s) {
                PyErr_Format(PyExc_TypeError, "%s: not C-contiguous", name);
                return -1;
            }
            s *= out->b.shape[d];
        }
    }
    return 0;
}

/* Release the held buffers among bs[0 .. n-1]. */
Py_LOCAL_INLINE(void) release(Buf *bs, int n) {
    for (int i = 0; i < n; i++)
        if (bs[i].held) {
            PyBuffer_Release(&bs[i].b);
            bs[i].held = 0;
        }
}

/* A ValueError naming the argument unless its shape is ``n0`` (and ``n1`` for a 2-D one;
 * -1: any). */
Py_LOCAL_INLINE(int) check_shape(const Buf *b, const char *name, Py_ssize_t n0, Py_ssize_t n1) {
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

/* A ValueError saying how shapes disagree (``what``), unless ``ok``. */
Py_LOCAL_INLINE(int) need(int ok, const char *what) {
    if (!ok)
        PyErr_Format(PyExc_ValueError, "%s", what);
    return ok ? 0 : -1;
}

/* A ValueError unless [start, end) lies within [0, n]. */
Py_LOCAL_INLINE(int) check_range(Py_ssize_t start, Py_ssize_t end, Py_ssize_t n) {
    if (start < 0 || end < start || end > n) {
        PyErr_Format(PyExc_ValueError, "range [%zd, %zd) is not within [0, %zd]", start, end,
                     n);
        return -1;
    }
    return 0;
}

/* Entry i of an integer buffer of item size ``size``, signed if ``sgn``. */
Py_LOCAL_INLINE(int64_t) ld(const char *p, Py_ssize_t size, int sgn, Py_ssize_t i) {
    switch (size) {
    case 1:
        return sgn ? (int64_t)((const int8_t *)p)[i] : (int64_t)((const uint8_t *)p)[i];
    case 2:
        return sgn ? (int64_t)((const int16_t *)p)[i] : (int64_t)((const uint16_t *)p)[i];
    case 4:
        return sgn ? (int64_t)((const int32_t *)p)[i] : (int64_t)((const uint32_t *)p)[i];
    default:
        return ((const int64_t *)p)[i];
    }
}

/* x into entry i of an integer buffer (the low bytes of its two's complement). */
Py_LOCAL_INLINE(void) st(char *p, Py_ssize_t size, Py_ssize_t i, int64_t x) {
    switch (size) {
    case 1:
        ((uint8_t *)p)[i] = (uint8_t)(uint64_t)x;
        break;
    case 2:
        ((uint16_t *)p)[i] = (uint16_t)(uint64_t)x;
        break;
    case 4:
        ((uint32_t *)p)[i] = (uint32_t)(uint64_t)x;
        break;
    default:
        ((int64_t *)p)[i] = x;
    }
}

/* An integer buffer as a loop reads it, held in locals, which no store can alias (a store
 * through a uint8 pointer may alias anything in memory, a Buf included). */
typedef struct {
    char *p;
    Py_ssize_t size;
    int sgn;
} Ix;

Py_LOCAL_INLINE(Ix) ix(const Buf *b) {
    Ix x;
    x.p = (char *)b->b.buf;
    x.size = b->b.itemsize;
    x.sgn = b->kind == 'i';
    return x;
}

#define LD(X, I) ld((X).p, (X).size, (X).sgn, (I))
#define ST(X, I, V) st((X).p, (X).size, (I), (V))

/* Entry i of the integer buffer ``b``. */
Py_LOCAL_INLINE(int64_t) buf_int(const Buf *b, Py_ssize_t i) {
    return ld((const char *)b->b.buf, b->b.itemsize, b->kind == 'i', i);
}

#endif

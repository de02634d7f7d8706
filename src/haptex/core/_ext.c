/*
 * haptex.core._ext: the CPython binding of the C core (the C API, METH_FASTCALL, buffers).
 *
 * Thin: it checks the buffers' types, shapes and the model (hx_model_check) before any
 * C reads them, then runs the batch loops with the GIL released. Validation of physical
 * parameters (ParameterError naming the parameter) happens in Python before this.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "hx_core.h"

static PyObject *core_error(int code)
{
    switch (code) {
    case HX_BAD_KIND:
        return PyErr_Format(PyExc_ValueError, "unknown texture kind");
    case HX_BAD_COEFFS:
        return PyErr_Format(PyExc_ValueError, "texture coefficients of the wrong shape or header");
    case HX_BAD_ALGORITHM:
        return PyErr_Format(PyExc_ValueError, "unknown algorithm code");
    case HX_NOT_IN_CORE:
        return PyErr_Format(PyExc_NotImplementedError, "this algorithm is not evaluated by the C core yet");
    default:
        return PyErr_Format(PyExc_RuntimeError, "C core error %d", code);
    }
}

/* A C-contiguous float64 buffer of ndim dimensions (ndim < 0: any). */
static int get_doubles(PyObject *obj, Py_buffer *view, int writable, int ndim, const char *what)
{
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    if (PyObject_GetBuffer(obj, view, flags) < 0)
        return -1;
    if (view->itemsize != 8 || view->format == NULL || strcmp(view->format, "d") != 0 ||
        (ndim >= 0 && view->ndim != ndim)) {
        PyErr_Format(PyExc_ValueError, "%s must be a C-contiguous float64 array%s", what,
                     ndim >= 0 ? " of the documented dimensions" : "");
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

/* The model from (code, prm, kind, coeffs); coeffs' buffer stays held by the caller. */
static int get_model(PyObject *const *args, hx_model *m, Py_buffer *prm, Py_buffer *coeffs)
{
    long code = PyLong_AsLong(args[0]), kind = PyLong_AsLong(args[2]);
    int rc, i;
    if ((code == -1 || kind == -1) && PyErr_Occurred())
        return -1;
    if (get_doubles(args[1], prm, 0, 1, "prm") < 0)
        return -1;
    if (prm->shape[0] != HX_N_PARAMS) {
        PyErr_Format(PyExc_ValueError, "prm must have %d values", HX_N_PARAMS);
        PyBuffer_Release(prm);
        return -1;
    }
    if (get_doubles(args[3], coeffs, 0, -1, "coeffs") < 0) {
        PyBuffer_Release(prm);
        return -1;
    }
    m->code = (int)code;
    for (i = 0; i < HX_N_PARAMS; i++)
        m->prm[i] = ((const double *)prm->buf)[i];
    m->tex.kind = (int)kind;
    m->tex.c = (const double *)coeffs->buf;
    m->tex.rows = coeffs->ndim == 2 ? (long)coeffs->shape[0] : 1;
    m->tex.cols = coeffs->ndim == 2 ? (long)coeffs->shape[1] : (coeffs->ndim == 1 ? (long)coeffs->shape[0] : 0);
    if (coeffs->ndim > 2 || (long)kind != m->tex.kind || (long)code != m->code) {
        rc = HX_BAD_COEFFS;
    } else {
        rc = hx_model_check(m);
    }
    if (rc != HX_OK) {
        PyBuffer_Release(prm);
        PyBuffer_Release(coeffs);
        core_error(rc);
        return -1;
    }
    return 0;
}

PyDoc_STRVAR(field_doc,
"field(code, prm, kind, coeffs, points, forces, jacobians)\n--\n\n"
"Forces (N) and Jacobians (N/m) of algorithm ``code`` at ``points`` (m), in place.\n\n"
"points: float64 (N, n), n = 2 ([x, z]) or 3 ([x, y, z]); forces: float64 (N, n);\n"
"jacobians: float64 (N, n, n) or None. The GIL is released during the loop.");

static PyObject *field(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    hx_model m;
    Py_buffer prm, coeffs, pts, frc, jb;
    Py_ssize_t n, i;
    int dim, with_jac, rc = HX_OK;
    (void)self;
    if (nargs != 7) {
        PyErr_SetString(PyExc_TypeError, "field takes 7 arguments");
        return NULL;
    }
    if (get_model(args, &m, &prm, &coeffs) < 0)
        return NULL;
    with_jac = args[6] != Py_None;
    if (get_doubles(args[4], &pts, 0, 2, "points") < 0)
        goto fail_model;
    if (get_doubles(args[5], &frc, 1, 2, "forces") < 0)
        goto fail_pts;
    if (with_jac && get_doubles(args[6], &jb, 1, 3, "jacobians") < 0)
        goto fail_frc;
    n = pts.shape[0];
    dim = (int)pts.shape[1];
    if ((dim != 2 && dim != 3) || frc.shape[0] != n || frc.shape[1] != dim ||
        (with_jac && (jb.shape[0] != n || jb.shape[1] != dim || jb.shape[2] != dim))) {
        PyErr_SetString(PyExc_ValueError, "points (N, n), forces (N, n) and jacobians (N, n, n) with n = 2 or 3");
        goto fail_all;
    }
    Py_BEGIN_ALLOW_THREADS
    {
        const double *p = (const double *)pts.buf;
        double *f = (double *)frc.buf, *J = with_jac ? (double *)jb.buf : NULL;
        for (i = 0; i < n && rc == HX_OK; i++) {
            double q[3], g[3], jac[9];
            if (dim == 3) {
                rc = hx_field(&m, p + 3 * i, f + 3 * i, J ? J + 9 * i : NULL);
                continue;
            }
            /* a profile: [x, z] -> [x, 0, z], the result's x and z rows and columns */
            q[0] = p[2 * i];
            q[1] = 0.0;
            q[2] = p[2 * i + 1];
            rc = hx_field(&m, q, g, J ? jac : NULL);
            f[2 * i] = g[0];
            f[2 * i + 1] = g[2];
            if (J) {
                J[4 * i] = jac[0];
                J[4 * i + 1] = jac[2];
                J[4 * i + 2] = jac[6];
                J[4 * i + 3] = jac[8];
            }
        }
    }
    Py_END_ALLOW_THREADS
    if (with_jac)
        PyBuffer_Release(&jb);
    PyBuffer_Release(&frc);
    PyBuffer_Release(&pts);
    PyBuffer_Release(&coeffs);
    PyBuffer_Release(&prm);
    if (rc != HX_OK)
        return core_error(rc);
    Py_RETURN_NONE;
fail_all:
    if (with_jac)
        PyBuffer_Release(&jb);
fail_frc:
    PyBuffer_Release(&frc);
fail_pts:
    PyBuffer_Release(&pts);
fail_model:
    PyBuffer_Release(&coeffs);
    PyBuffer_Release(&prm);
    return NULL;
}

PyDoc_STRVAR(texture_doc,
"texture(kind, coeffs, xy, out)\n--\n\n"
"h, h_x, h_y, h_xx, h_xy, h_yy (m, m/m, 1/m) at in-plane points ``xy`` (float64 (N, 2), m)\n"
"into ``out`` (float64 (N, 6)); a profile reads x and ignores y.");

static PyObject *texture(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer coeffs, xy, out;
    hx_texture t;
    long kind;
    int rc;
    Py_ssize_t i, n;
    (void)self;
    if (nargs != 4) {
        PyErr_SetString(PyExc_TypeError, "texture takes 4 arguments");
        return NULL;
    }
    kind = PyLong_AsLong(args[0]);
    if (kind == -1 && PyErr_Occurred())
        return NULL;
    if (get_doubles(args[1], &coeffs, 0, -1, "coeffs") < 0)
        return NULL;
    t.kind = (int)kind;
    t.c = (const double *)coeffs.buf;
    t.rows = coeffs.ndim == 2 ? (long)coeffs.shape[0] : 1;
    t.cols = coeffs.ndim == 2 ? (long)coeffs.shape[1] : (coeffs.ndim == 1 ? (long)coeffs.shape[0] : 0);
    rc = coeffs.ndim > 2 || (long)t.kind != kind ? HX_BAD_COEFFS : hx_texture_check(t.kind, t.c, t.rows, t.cols);
    if (rc != HX_OK) {
        PyBuffer_Release(&coeffs);
        return core_error(rc);
    }
    if (get_doubles(args[2], &xy, 0, 2, "xy") < 0) {
        PyBuffer_Release(&coeffs);
        return NULL;
    }
    if (get_doubles(args[3], &out, 1, 2, "out") < 0) {
        PyBuffer_Release(&xy);
        PyBuffer_Release(&coeffs);
        return NULL;
    }
    n = xy.shape[0];
    if (xy.shape[1] != 2 || out.shape[0] != n || out.shape[1] != 6) {
        PyBuffer_Release(&out);
        PyBuffer_Release(&xy);
        PyBuffer_Release(&coeffs);
        PyErr_SetString(PyExc_ValueError, "xy must be (N, 2) and out (N, 6)");
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS
    {
        const double *p = (const double *)xy.buf;
        double *o = (double *)out.buf;
        for (i = 0; i < n; i++) {
            hx_height hh;
            hx_texture_eval(&t, p[2 * i], p[2 * i + 1], &hh);
            o[6 * i] = hh.h;
            o[6 * i + 1] = hh.gx;
            o[6 * i + 2] = hh.gy;
            o[6 * i + 3] = hh.hxx;
            o[6 * i + 4] = hh.hxy;
            o[6 * i + 5] = hh.hyy;
        }
    }
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&out);
    PyBuffer_Release(&xy);
    PyBuffer_Release(&coeffs);
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"field", (PyCFunction)(void (*)(void))field, METH_FASTCALL, field_doc},
    {"texture", (PyCFunction)(void (*)(void))texture, METH_FASTCALL, texture_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_ext", "haptex's C core (see haptex.core).", -1, methods,
    NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__ext(void)
{
    PyObject *mod = PyModule_Create(&module);
    struct { const char *name; int value; } consts[] = {
        {"TEXTURE_FLAT", HX_TEXTURE_FLAT}, {"TEXTURE_FOURIER", HX_TEXTURE_FOURIER},
        {"TEXTURE_SPLINE", HX_TEXTURE_SPLINE}, {"SURFACE_GRATINGS", HX_SURFACE_GRATINGS},
        {"SURFACE_PATCHES", HX_SURFACE_PATCHES},
        {"ALG_W", HX_ALG_W}, {"ALG_A", HX_ALG_A}, {"ALG_B", HX_ALG_B}, {"ALG_C", HX_ALG_C},
        {"ALG_D", HX_ALG_D}, {"ALG_E", HX_ALG_E}, {"ALG_F", HX_ALG_F}, {"ALG_G", HX_ALG_G},
        {"N_PARAMS", HX_N_PARAMS}, {"P_K0", HX_P_K0}, {"P_DZMAX", HX_P_DZMAX}, {"P_MU", HX_P_MU},
        {"P_DXMAX", HX_P_DXMAX}, {"P_SCALE", HX_P_SCALE}, {"P_ZSTICK", HX_P_ZSTICK},
    };
    size_t i;
    if (mod == NULL)
        return NULL;
    for (i = 0; i < sizeof consts / sizeof consts[0]; i++) {
        if (PyModule_AddIntConstant(mod, consts[i].name, consts[i].value) < 0) {
            Py_DECREF(mod);
            return NULL;
        }
    }
    return mod;
}

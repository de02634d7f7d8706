/*
 * haptex.core._ext: the CPython binding of the C core (the C API, METH_FASTCALL, buffers).
 *
 * Thin: it checks the buffers' types, shapes and the model (hx_model_check) before any
 * C reads them, then runs the batch loops with the GIL released. Validation of physical
 * parameters (ParameterError naming the parameter) happens in Python before this.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <structmember.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#define NPY_NO_DEPRECATED_API NPY_1_22_API_VERSION
#include <numpy/arrayobject.h> /* step's fast path for a NumPy row (its data read in place) */

#include "hx_core.h"
#include "hx_host.h"

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

/* t over a coefficient buffer v (a 1-D array one row): HX_BAD_COEFFS past 2 dimensions or for a
 * kind past an int, else HX_OK (its coefficients not yet checked: hx_texture_check) */
static int texture_over(hx_texture *t, long kind, const Py_buffer *v)
{
    t->kind = (int)kind;
    t->c = (const double *)v->buf;
    t->rows = v->ndim == 2 ? (long)v->shape[0] : 1;
    t->cols = v->ndim == 2 ? (long)v->shape[1] : (v->ndim == 1 ? (long)v->shape[0] : 0);
    return v->ndim > 2 || (long)t->kind != kind ? HX_BAD_COEFFS : HX_OK;
}

/* ---- Checked: a texture's coefficients copied once and checked once ----------------------
 * hx_texture_check reads every cell's start in a map with branched cells (a felt map's: 33 MB
 * and 0.4 ms a call on a 688 x 352 map), once a call of texture, field and closest_surface.
 * checked(kind, coeffs) copies the coefficients into memory of its own, checks them, and
 * returns a read-only NumPy array over that memory whose base is the Checked object; NumPy
 * lets no view of it be made writeable (its base exports no buffer), so the entry points skip
 * their check for an array over exactly that memory, kind and shape (already_checked). */
typedef struct {
    PyObject_HEAD
    int kind;
    long rows, cols;
    double *data;
} CheckedObject;

static void Checked_dealloc(CheckedObject *self)
{
    PyMem_Free(self->data);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static PyTypeObject CheckedType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "haptex.core._ext.Checked",
    .tp_basicsize = sizeof(CheckedObject),
    .tp_dealloc = (destructor)Checked_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "The memory of a texture's coefficients copied and checked once (made by checked(); the base of its array).",
};

static long full_checks; /* hx_texture_check runs on a texture's coefficients (checks()) */

/* coeffs' array (obj, its buffer v) over a Checked copy's memory of this kind and shape */
static int already_checked(PyObject *obj, const Py_buffer *v, long kind, long rows, long cols)
{
    int depth;
    const CheckedObject *chk;
    for (depth = 0; depth < 8 && obj != NULL && PyArray_Check(obj); depth++)
        obj = PyArray_BASE((PyArrayObject *)obj);
    if (obj == NULL || !Py_IS_TYPE(obj, &CheckedType))
        return 0;
    chk = (const CheckedObject *)obj;
    return chk->kind == kind && chk->rows == rows && chk->cols == cols && v->buf == (void *)chk->data &&
           v->len == (Py_ssize_t)(rows * cols) * (Py_ssize_t)sizeof(double);
}

/* hx_texture_check of t, unless its coefficients (obj, buffer v) are a Checked copy's */
static int texture_check(PyObject *obj, const Py_buffer *v, const hx_texture *t)
{
    if (already_checked(obj, v, t->kind, t->rows, t->cols))
        return HX_OK;
    full_checks++;
    return hx_texture_check(t->kind, t->c, t->rows, t->cols);
}

/* t over the coefficients (obj, buffer v) of this kind, checked (texture_over, texture_check): HX_OK or the
 * first failure's code */
static int texture_of(hx_texture *t, long kind, PyObject *obj, const Py_buffer *v)
{
    int rc = texture_over(t, kind, v);
    return rc == HX_OK ? texture_check(obj, v, t) : rc;
}

PyDoc_STRVAR(checked_doc,
"checked(kind, coeffs)\n--\n\n"
"A read-only float64 array of coeffs' shape (1 or 2 dimensions) holding a copy of them, checked\n"
"once (ValueError as texture's); texture, field and closest_surface do not check it again.");

static PyObject *checked(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    long kind;
    Py_buffer v;
    hx_texture t;
    CheckedObject *chk;
    PyObject *arr;
    npy_intp dims[2];
    int rc, ndim;
    (void)self;
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "checked takes 2 arguments");
        return NULL;
    }
    kind = PyLong_AsLong(args[0]);
    if (kind == -1 && PyErr_Occurred())
        return NULL;
    if (get_doubles(args[1], &v, 0, -1, "coeffs") < 0)
        return NULL;
    ndim = v.ndim;
    if (ndim < 1 || texture_over(&t, kind, &v) != HX_OK) {
        PyBuffer_Release(&v);
        return core_error(HX_BAD_COEFFS);
    }
    dims[0] = v.shape[0];
    dims[1] = ndim == 2 ? v.shape[1] : 1;
    chk = PyObject_New(CheckedObject, &CheckedType);
    if (chk == NULL) {
        PyBuffer_Release(&v);
        return NULL;
    }
    chk->kind = t.kind;
    chk->rows = t.rows;
    chk->cols = t.cols;
    chk->data = (double *)PyMem_Malloc(v.len > 0 ? (size_t)v.len : sizeof(double));
    if (chk->data == NULL) {
        PyBuffer_Release(&v);
        Py_DECREF(chk);
        return PyErr_NoMemory();
    }
    memcpy(chk->data, v.buf, (size_t)v.len);
    PyBuffer_Release(&v);
    full_checks++;
    rc = hx_texture_check(chk->kind, chk->data, chk->rows, chk->cols); /* (on the copy: what is read later) */
    if (rc != HX_OK) {
        Py_DECREF(chk);
        return core_error(rc);
    }
    arr = PyArray_New(&PyArray_Type, ndim, dims, NPY_DOUBLE, NULL, chk->data, 0, NPY_ARRAY_C_CONTIGUOUS | NPY_ARRAY_ALIGNED,
                      NULL);
    if (arr == NULL) {
        Py_DECREF(chk);
        return NULL;
    }
    if (PyArray_SetBaseObject((PyArrayObject *)arr, (PyObject *)chk) < 0) { /* (steals chk) */
        Py_DECREF(arr);
        return NULL;
    }
    return arr;
}

PyDoc_STRVAR(checks_doc,
"checks()\n--\n\n"
"How many times a texture's coefficients were checked whole (hx_texture_check) by texture, field,\n"
"closest_surface and checked since the module was loaded: counted work, for tests.");

static PyObject *checks(PyObject *self, PyObject *unused)
{
    (void)self;
    (void)unused;
    return PyLong_FromLong(full_checks);
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
    m->base = NULL;
    for (i = 0; i < HX_N_PARAMS; i++)
        m->prm[i] = ((const double *)prm->buf)[i];
    if (texture_over(&m->tex, kind, coeffs) != HX_OK || (long)code != m->code) {
        rc = HX_BAD_COEFFS;
    } else {
        rc = texture_check(args[3], coeffs, &m->tex);
        if (rc == HX_OK)
            rc = hx__model_check(m, 1);
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
    rc = texture_of(&t, kind, args[1], &coeffs);
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


/* ---- Base: an object's base surface (hx_base), its arrays owned, a mesh's hierarchy built ---- */

typedef struct {
    PyObject_HEAD
    hx_base base;
    double *tri, *face, *box;
    long *node, *order;
} BaseObject;

static void Base_free(BaseObject *self)
{
    free(self->tri);
    free(self->face);
    free(self->box);
    free(self->node);
    free(self->order);
    self->tri = self->face = self->box = NULL;
    self->node = self->order = NULL;
}

static void Base_dealloc(BaseObject *self)
{
    Base_free(self);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int Base_init(BaseObject *self, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"kind", "radius", "tri", "face", "prism", NULL};
    int kind, prism = 0;
    double radius;
    PyObject *tri_obj, *face_obj;
    Py_buffer tri, face;
    hx_base *b = &self->base;
    long n;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "idOO|p", kwlist, &kind, &radius, &tri_obj, &face_obj, &prism))
        return -1;
    Base_free(self);
    memset(b, 0, sizeof *b);
    b->kind = kind;
    b->radius = radius;
    b->prism = kind == HX_BASE_MESH && prism;
    if (kind == HX_BASE_MESH) {
        if (get_doubles(tri_obj, &tri, 0, 2, "tri") < 0)
            return -1;
        if (get_doubles(face_obj, &face, 0, 2, "face") < 0) {
            PyBuffer_Release(&tri);
            return -1;
        }
        if (tri.shape[1] != 9 || face.shape[1] != HX_FACE || face.shape[0] != tri.shape[0] || tri.shape[0] < 1) {
            PyBuffer_Release(&face);
            PyBuffer_Release(&tri);
            PyErr_Format(PyExc_ValueError, "a mesh base needs tri (n, 9) and face (n, %d), n >= 1", HX_FACE);
            return -1;
        }
        n = (long)tri.shape[0];
        self->tri = malloc((size_t)tri.len);
        self->face = malloc((size_t)face.len);
        self->box = malloc(sizeof(double) * 12 * (size_t)n);
        self->node = malloc(sizeof(long) * 4 * (size_t)n);
        self->order = malloc(sizeof(long) * (size_t)n);
        if (!self->tri || !self->face || !self->box || !self->node || !self->order) {
            PyBuffer_Release(&face);
            PyBuffer_Release(&tri);
            Base_free(self);
            PyErr_NoMemory();
            return -1;
        }
        memcpy(self->tri, tri.buf, (size_t)tri.len);
        memcpy(self->face, face.buf, (size_t)face.len);
        PyBuffer_Release(&face);
        PyBuffer_Release(&tri);
        b->n_tri = n;
        Py_BEGIN_ALLOW_THREADS
        b->n_node = hx_bvh_build(self->tri, n, self->order, self->box, self->node);
        Py_END_ALLOW_THREADS
        b->tri = self->tri;
        b->face = self->face;
        b->box = self->box;
        b->node = self->node;
        b->order = self->order;
    }
    if (hx_base_check(b) != HX_OK) {
        PyErr_SetString(PyExc_ValueError, "base: an unknown kind, a radius not in (0, inf), or a hierarchy failing "
                                          "its check");
        return -1;
    }
    return 0;
}

PyDoc_STRVAR(base_closest_doc, "closest(points, tri, bary, dist2)\n--\n\nA mesh's closest point to each row of "
                               "points (float64 (N, 3), m), exact: its triangle into tri (int64 (N,)), barycentric "
                               "coordinates into bary (float64 (N, 3)), squared distance (m^2) into dist2 (float64 "
                               "(N,)); returns the nodes and triangles visited. The GIL is released.");

static PyObject *Base_closest(BaseObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer b[4];
    Py_ssize_t i, n;
    long work = 0;
    int k, ok = 1;
    if (nargs != 4 || self->base.kind != HX_BASE_MESH) {
        PyErr_SetString(PyExc_TypeError, "closest takes points, tri, bary and dist2, on a mesh");
        return NULL;
    }
    for (k = 0; k < 4; k++) {
        int rc = k == 1 ? PyObject_GetBuffer(args[1], &b[1], PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_WRITABLE)
                        : get_doubles(args[k], &b[k], k > 0, k == 3 ? 1 : 2, k == 0 ? "points" : k == 2 ? "bary" : "dist2");
        if (rc < 0) {
            while (--k >= 0)
                PyBuffer_Release(&b[k]);
            return NULL;
        }
    }
    n = b[0].shape[0];
    if (b[0].shape[1] != 3 || b[1].ndim != 1 || b[1].itemsize != 8 || b[1].shape[0] != n ||
        (strcmp(b[1].format, "l") != 0 && strcmp(b[1].format, "q") != 0) || b[2].shape[0] != n ||
        b[2].shape[1] != 3 || b[3].shape[0] != n)
        ok = 0;
    if (ok) {
        Py_BEGIN_ALLOW_THREADS
        {
            const double *p = b[0].buf;
            long long *tri = b[1].buf;
            double *bary = b[2].buf, *d2 = b[3].buf;
            long warm = -1;
            for (i = 0; i < n; i++) { /* (each point warm-starts the next: neighbours in a grid) */
                long t;
                work += hx_mesh_closest(&self->base, p + 3 * i, warm, &t, bary + 3 * i, d2 + i);
                tri[i] = t;
                warm = t;
            }
        }
        Py_END_ALLOW_THREADS
    }
    for (k = 0; k < 4; k++)
        PyBuffer_Release(&b[k]);
    if (!ok) {
        PyErr_SetString(PyExc_ValueError, "points (N, 3), tri int64 (N,), bary (N, 3), dist2 (N,)");
        return NULL;
    }
    return PyLong_FromLong(work);
}

static PyMethodDef Base_methods[] = {
    {"closest", (PyCFunction)(void (*)(void))Base_closest, METH_FASTCALL, base_closest_doc},
    {NULL, NULL, 0, NULL},
};

static PyMemberDef Base_members[] = {
    {"kind", T_INT, offsetof(BaseObject, base.kind), READONLY, "BASE_*"},
    {"nodes", T_LONG, offsetof(BaseObject, base.n_node), READONLY, "a mesh's hierarchy's nodes"},
    {"triangles", T_LONG, offsetof(BaseObject, base.n_tri), READONLY, "a mesh's triangles"},
    {NULL, 0, 0, 0, NULL},
};

static PyTypeObject BaseType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "haptex.core._ext.Base",
    .tp_basicsize = sizeof(BaseObject),
    .tp_dealloc = (destructor)Base_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "An object's base surface for the C core: Base(kind, radius, tri, face); a mesh's arrays copied and "
              "its bounding-volume hierarchy built (hx_bvh_build).",
    .tp_methods = Base_methods,
    .tp_members = Base_members,
    .tp_init = (initproc)Base_init,
    .tp_new = PyType_GenericNew,
};

/* ---- Renderer: one hx_renderer, its own copy of the coefficients ------------------ */

typedef struct {
    PyObject_HEAD
    hx_renderer r;
    double *coeffs; /* owned copies: the model never points into a Python object */
    double *aux;
    int dim;        /* 2: [x, z]; 3: [x, y, z] */
    PyObject *fallback; /* called with p when step's fast path does not apply */
    PyObject *base; /* an object's base (a Base; model.base points into it), or NULL */
    double *vib;    /* an owned copy of the vibration's model set (r.vib points into it), or NULL */
    PyObject *model_current; /* the Renderer whose arrays the model set by set_model uses, or NULL */
    PyObject *model_next;    /* the one whose model waits for the next tick, or NULL (set_model) */
} RendererObject;

static PyTypeObject RendererType; /* (defined below) */

static void Renderer_dealloc(RendererObject *self)
{
    Py_XDECREF(self->model_current);
    Py_XDECREF(self->model_next);
    Py_XDECREF(self->base);
    free(self->vib);
    free(self->coeffs);
    free(self->aux);
    Py_XDECREF(self->fallback);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int Renderer_init(RendererObject *self, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"code", "prm", "kind", "coeffs", "aux", "dim", "max_force", "limit", "monitor",
                             "controller", "max_damping", "mode", "period", "fallback", "delay", "base",
                             NULL};
    int code, kind, dim, monitor, on, stored, rc, i, delay = 0; /* stored: the stabiliser's mode */
    double max_force, limit, bmax, T;
    PyObject *prm_obj, *coeffs_obj, *aux_obj, *fallback, *base = Py_None;
    Py_buffer prm, coeffs, aux;
    size_t bytes;
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "iOiOOiddppdidO|iO", kwlist, &code, &prm_obj, &kind, &coeffs_obj,
                                     &aux_obj, &dim, &max_force, &limit, &monitor, &on, &bmax, &stored, &T, &fallback,
                                     &delay, &base))
        return -1;
    if (base != Py_None && (dim != 3 || !Py_IS_TYPE(base, &BaseType))) {
        PyErr_SetString(PyExc_ValueError, "base must be None or a Base, in 3-D");
        return -1;
    }
    if (stored < 0 || stored >= HX_N_STAB) {
        PyErr_SetString(PyExc_ValueError, "mode must be one of the HX_STAB_* codes");
        return -1;
    }
    if (delay < 0 || delay >= HX_PC_RING) {
        PyErr_Format(PyExc_ValueError, "delay must be 0 to %d", HX_PC_RING - 1);
        return -1;
    }
    if (dim != 2 && dim != 3) {
        PyErr_SetString(PyExc_ValueError, "dim must be 2 or 3");
        return -1;
    }
    if (!PyCallable_Check(fallback)) {
        PyErr_SetString(PyExc_TypeError, "fallback must be callable");
        return -1;
    }
    if (get_doubles(prm_obj, &prm, 0, 1, "prm") < 0)
        return -1;
    if (prm.shape[0] != HX_N_PARAMS) {
        PyBuffer_Release(&prm);
        PyErr_Format(PyExc_ValueError, "prm must have %d values", HX_N_PARAMS);
        return -1;
    }
    if (get_doubles(coeffs_obj, &coeffs, 0, -1, "coeffs") < 0 || coeffs.ndim > 2) {
        if (!PyErr_Occurred()) {
            PyBuffer_Release(&coeffs);
            PyErr_SetString(PyExc_ValueError, "coeffs must have at most 2 dimensions");
        }
        PyBuffer_Release(&prm);
        return -1;
    }
    if (get_doubles(aux_obj, &aux, 0, 1, "aux") < 0) {
        PyBuffer_Release(&coeffs);
        PyBuffer_Release(&prm);
        return -1;
    }
    memset(&self->r, 0, sizeof self->r);
    free(self->coeffs);
    free(self->aux);
    bytes = (size_t)coeffs.len > 0 ? (size_t)coeffs.len : sizeof(double);
    self->coeffs = malloc(bytes);
    self->aux = malloc((size_t)aux.len > 0 ? (size_t)aux.len : sizeof(double));
    if (self->coeffs == NULL || self->aux == NULL) {
        PyBuffer_Release(&aux);
        PyBuffer_Release(&coeffs);
        PyBuffer_Release(&prm);
        PyErr_NoMemory();
        return -1;
    }
    memcpy(self->coeffs, coeffs.buf, (size_t)coeffs.len);
    memcpy(self->aux, aux.buf, (size_t)aux.len);
    self->r.model.aux = self->aux;
    self->r.model.naux = (long)aux.shape[0];
    PyBuffer_Release(&aux);
    self->r.model.code = code;
    for (i = 0; i < HX_N_PARAMS; i++)
        self->r.model.prm[i] = ((const double *)prm.buf)[i];
    texture_over(&self->r.model.tex, kind, &coeffs); /* (at most 2 dimensions: checked above) */
    self->r.model.tex.c = self->coeffs;
    PyBuffer_Release(&coeffs);
    PyBuffer_Release(&prm);
    Py_CLEAR(self->base);
    if (base != Py_None) {
        Py_INCREF(base);
        self->base = base;
        self->r.model.base = &((BaseObject *)base)->base;
    }
    rc = hx_model_check(&self->r.model);

    if (rc != HX_OK) {
        core_error(rc);
        return -1;
    }
    self->dim = dim;
    self->r.max_force = max_force;
    self->r.limit = limit;
    self->r.monitor = monitor || on;
    self->r.pc.on = on;
    self->r.pc.bmax = bmax;
    self->r.pc.mode = stored;
    self->r.pc.T = T;
    self->r.pc.delay = delay;
    Py_INCREF(fallback);
    Py_XSETREF(self->fallback, fallback);
    return 0;
}

static PyObject *make_tuple(const RendererObject *self, const double f[3])
{
    PyObject *t = PyTuple_New(self->dim);
    int i, k = 0;
    if (t == NULL)
        return NULL;
    for (i = 0; i < 3; i++) {
        PyObject *v;
        if (self->dim == 2 && i == 1)
            continue;
        v = PyFloat_FromDouble(f[i]);
        if (v == NULL) {
            Py_DECREF(t);
            return NULL;
        }
        PyTuple_SET_ITEM(t, k++, v);
    }
    return t;
}

PyDoc_STRVAR(step_doc, "step(p)\n--\n\nThe force (N) for one probe position p (m): the fast path for a tuple or list of "
                       "plain floats, else the fallback given at construction.");

/* step's fast path for a NumPy row: exactly dim float64 in native byte order, one dimension, any
   stride; any other array (another dtype, shape or length) goes to the checked path. */
static PyObject *step_array(RendererObject *self, PyArrayObject *a)
{
    double q[3] = {0.0, 0.0, 0.0}, f[3];
    const char *b;
    npy_intp st;
    if (PyArray_TYPE(a) != NPY_DOUBLE || PyArray_NDIM(a) != 1 || PyArray_DIM(a, 0) != self->dim ||
        !PyArray_ISNOTSWAPPED(a))
        return PyObject_CallOneArg(self->fallback, (PyObject *)a);
    b = (const char *)PyArray_DATA(a);
    st = PyArray_STRIDE(a, 0);
    q[0] = *(const double *)b;
    if (self->dim == 3) {
        q[1] = *(const double *)(b + st);
        q[2] = *(const double *)(b + 2 * st);
    } else {
        q[2] = *(const double *)(b + st);
    }
    hx_render_step(&self->r, q[0], q[1], q[2], f);
    return make_tuple(self, f);
}

static PyObject *Renderer_step(RendererObject *self, PyObject *p)
{
    PyObject **items;
    double q[3], f[3];
    Py_ssize_t n;
    if (PyTuple_CheckExact(p)) {
        n = PyTuple_GET_SIZE(p);
        items = &PyTuple_GET_ITEM(p, 0);
    } else if (PyList_CheckExact(p)) {
        n = PyList_GET_SIZE(p);
        items = PyList_GET_SIZE(p) ? &PyList_GET_ITEM(p, 0) : NULL;
    } else if (PyArray_Check(p)) {
        return step_array(self, (PyArrayObject *)p);
    } else {
        return PyObject_CallOneArg(self->fallback, p);
    }
    if (n != self->dim || !PyFloat_CheckExact(items[0]) || !PyFloat_CheckExact(items[1]) ||
        (n == 3 && !PyFloat_CheckExact(items[2])))
        return PyObject_CallOneArg(self->fallback, p);
    q[0] = PyFloat_AS_DOUBLE(items[0]);
    if (n == 3) {
        q[1] = PyFloat_AS_DOUBLE(items[1]);
        q[2] = PyFloat_AS_DOUBLE(items[2]);
    } else {
        q[1] = 0.0;
        q[2] = PyFloat_AS_DOUBLE(items[1]);
    }
    hx_render_step(&self->r, q[0], q[1], q[2], f);
    return make_tuple(self, f);
}

PyDoc_STRVAR(tick_doc, "tick(x, y, z)\n--\n\nThe force (fx, fy, fz) (N) at (x, y, z) (m, floats; y = 0 and fy = 0 "
                       "over a profile).");

static PyObject *Renderer_tick(RendererObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double q[3], f[3];
    int i;
    if (nargs != 3) {
        PyErr_SetString(PyExc_TypeError, "tick takes x, y, z");
        return NULL;
    }
    for (i = 0; i < 3; i++) {
        q[i] = PyFloat_AsDouble(args[i]);
        if (q[i] == -1.0 && PyErr_Occurred())
            return NULL;
    }
    hx_render_step(&self->r, q[0], q[1], q[2], f);
    return Py_BuildValue("(ddd)", f[0], f[1], f[2]);
}

PyDoc_STRVAR(run_doc, "run(points, forces)\n--\n\nTicks over every row of points (float64 (N, dim), m) in "
                      "order, the forces (N) into forces (float64 (N, dim)); the GIL released.");

static PyObject *Renderer_run(RendererObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer pts, frc;
    Py_ssize_t i, n;
    int dim = self->dim;
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "run takes points and forces");
        return NULL;
    }
    if (get_doubles(args[0], &pts, 0, 2, "points") < 0)
        return NULL;
    if (get_doubles(args[1], &frc, 1, 2, "forces") < 0) {
        PyBuffer_Release(&pts);
        return NULL;
    }
    n = pts.shape[0];
    if (pts.shape[1] != dim || frc.shape[0] != n || frc.shape[1] != dim) {
        PyBuffer_Release(&frc);
        PyBuffer_Release(&pts);
        PyErr_SetString(PyExc_ValueError, "points and forces must both be (N, dim)");
        return NULL;
    }
    Py_BEGIN_ALLOW_THREADS
    {
        const double *p = (const double *)pts.buf;
        double *out = (double *)frc.buf, f[3];
        for (i = 0; i < n; i++) {
            const double *q = p + dim * i;
            if (dim == 3) {
                hx_render_step(&self->r, q[0], q[1], q[2], out + 3 * i);
            } else {
                hx_render_step(&self->r, q[0], 0.0, q[1], f);
                out[2 * i] = f[0];
                out[2 * i + 1] = f[2];
            }
        }
    }
    Py_END_ALLOW_THREADS
    PyBuffer_Release(&frc);
    PyBuffer_Release(&pts);
    Py_RETURN_NONE;
}

static PyObject *Renderer_fault(RendererObject *self, PyObject *unused)
{
    (void)unused;
    self->r.faults++;
    hx_passivity_skip(&self->r.pc);
    self->r.work = 0;
    Py_RETURN_NONE;
}

static PyObject *Renderer_set_stiffness(RendererObject *self, PyObject *arg)
{
    double k0 = PyFloat_AsDouble(arg);
    if (k0 == -1.0 && PyErr_Occurred())
        return NULL;
    if (!isfinite(k0) || !(k0 > 0.0)) {
        PyErr_SetString(PyExc_ValueError, "stiffness must be finite and > 0 (N/m)");
        return NULL;
    }
    hx_render_set_stiffness(&self->r, k0);
    Py_RETURN_NONE;
}

static PyObject *Renderer_set_model(RendererObject *self, PyObject *arg)
{
    RendererObject *o = (RendererObject *)arg;
    int withdrawn;
    if (!Py_IS_TYPE(arg, &RendererType) || arg == (PyObject *)self || o->dim != self->dim) {
        PyErr_SetString(PyExc_ValueError, "set_model takes another Renderer core of the same dimension");
        return NULL;
    }
    /* with the GIL held: one writer at a time (it waits at most for a tick's copy of a struct) */
    withdrawn = hx_render_set_model(&self->r, &o->r.model);
    /* the arrays in use: the last model handed, if a tick took it (else it was withdrawn unused) */
    if (self->model_next != NULL && !withdrawn)
        Py_XSETREF(self->model_current, self->model_next);
    else
        Py_XDECREF(self->model_next);
    Py_INCREF(arg);
    self->model_next = arg;
    Py_RETURN_NONE;
}

static PyObject *Renderer_get_stiffness(RendererObject *self, void *closure)
{
    double k0;
    (void)closure;
    HX_LOAD_DOUBLE_RLX(&self->r.model.prm[HX_P_K0], &k0);
    return PyFloat_FromDouble(k0);
}

static PyObject *Renderer_reset(RendererObject *self, PyObject *unused)
{
    (void)unused;
    hx_render_reset(&self->r);
    Py_RETURN_NONE;
}

static PyObject *Renderer_energy_axis(RendererObject *self, void *closure)
{
    (void)closure;
    return make_tuple(self, self->r.pc.e_axis);
}

static PyObject *Renderer_adhesion(RendererObject *self, void *closure)
{
    (void)closure;
    if (!(self->r.model.code == HX_ALG_F && self->r.st.contact) &&
        !(self->r.model.code == HX_ALG_PROXY && self->r.st.contact == 1))
        Py_RETURN_NONE;
    return Py_BuildValue("(dd)", self->r.st.adh[0], self->r.st.adh[1]);
}

PyDoc_STRVAR(set_vibration_doc, "set_vibration(v, mass, gain, tau, seed)\n--\n\nLayer the data-driven vibration "
                                "of model set v (hx_vibration.c's layout, checked; copied) on the texture: mass (kg) x "
                                "gain x its acceleration along the filtered tangential velocity (time constant tau, s), "
                                "its noise seeded with seed; v = None removes it.");

/* A vibration's settings from a (v, mass, gain, tau, seed[, budget, reserve]) argument list of
 * nargs (5 or 7) objects: v's buffer (checked by hx_vib_check; the caller releases it) and the
 * numbers checked; 0, or -1 with an exception set. */
static int vib_settings(PyObject *const *args, Py_ssize_t nargs, Py_buffer *v, double *mass, double *gain,
                        double *tau, unsigned long long *seed, double *budget, double *reserve)
{
    int rc;
    *budget = -1.0;
    *reserve = 0.0;
    if (nargs != 5 && nargs != 7) {
        PyErr_SetString(PyExc_TypeError, "a vibration takes v, mass, gain, tau, seed[, budget, reserve]");
        return -1;
    }
    *mass = PyFloat_AsDouble(args[1]);
    *gain = PyFloat_AsDouble(args[2]);
    *tau = PyFloat_AsDouble(args[3]);
    *seed = PyLong_AsUnsignedLongLongMask(args[4]);
    if (nargs == 7) {
        *budget = args[5] == Py_None ? -1.0 : PyFloat_AsDouble(args[5]);
        *reserve = PyFloat_AsDouble(args[6]);
    }
    if (PyErr_Occurred())
        return -1;
    if (!(*reserve >= 0.0 && isfinite(*reserve)) || !isfinite(*budget)) {
        PyErr_SetString(PyExc_ValueError, "budget (W, None for none) and reserve >= 0 (J) must be finite");
        return -1;
    }
    if (!(*mass > 0.0 && isfinite(*mass)) || !(*gain >= 0.0 && isfinite(*gain)) || !(*tau >= 0.0 && isfinite(*tau))) {
        PyErr_SetString(PyExc_ValueError, "mass > 0, gain >= 0 and tau >= 0 must be finite");
        return -1;
    }
    if (get_doubles(args[0], v, 0, 1, "v") < 0)
        return -1;
    rc = hx_vib_check((const double *)v->buf, (long)v->shape[0]);
    if (rc != HX_OK) {
        PyBuffer_Release(v);
        core_error(rc);
        return -1;
    }
    return 0;
}

static PyObject *Renderer_set_vibration(RendererObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer v;
    double mass, gain, tau, budget, reserve;
    unsigned long long seed;
    double *copy;
    if (nargs >= 1 && args[0] == Py_None) {
        self->r.vib.set = NULL;
        free(self->vib);
        self->vib = NULL;
        Py_RETURN_NONE;
    }
    if (vib_settings(args, nargs, &v, &mass, &gain, &tau, &seed, &budget, &reserve) < 0)
        return NULL;
    copy = (double *)malloc((size_t)v.shape[0] * sizeof(double));
    if (copy == NULL) {
        PyBuffer_Release(&v);
        return PyErr_NoMemory();
    }
    memcpy(copy, v.buf, (size_t)v.shape[0] * sizeof(double));
    PyBuffer_Release(&v);
    self->r.vib.set = NULL;
    free(self->vib);
    self->vib = copy;
    hx_render_set_vibration(&self->r, copy, mass, gain, tau, seed, budget, reserve);
    Py_RETURN_NONE;
}

static PyObject *Renderer_set_friction(RendererObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double mu, vth;
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "set_friction takes 2 arguments (mu, v_threshold)");
        return NULL;
    }
    mu = PyFloat_AsDouble(args[0]);
    vth = PyFloat_AsDouble(args[1]);
    if (PyErr_Occurred())
        return NULL;
    if (!(isfinite(mu) && mu >= 0.0 && isfinite(vth) && vth > 0.0)) {
        PyErr_SetString(PyExc_ValueError, "set_friction: mu >= 0 and v_threshold > 0, finite");
        return NULL;
    }
    hx_vib_channel_set_friction(&self->r.vib, mu, vth);
    Py_RETURN_NONE;
}

static PyMethodDef Renderer_methods[] = {
    {"set_vibration", (PyCFunction)(void (*)(void))Renderer_set_vibration, METH_FASTCALL, set_vibration_doc},
    {"set_friction", (PyCFunction)(void (*)(void))Renderer_set_friction, METH_FASTCALL,
     "set_friction(mu, v_threshold)\n--\n\nThe material's kinetic friction beside the vibration "
     "(hx_vib_channel_set_friction): mu f_z against the tangential velocity, viscous below v_threshold (m/s); "
     "after set_vibration, which turns it off."},
    {"step", (PyCFunction)Renderer_step, METH_O, step_doc},
    {"tick", (PyCFunction)(void (*)(void))Renderer_tick, METH_FASTCALL, tick_doc},
    {"run", (PyCFunction)(void (*)(void))Renderer_run, METH_FASTCALL, run_doc},
    {"fault", (PyCFunction)Renderer_fault, METH_NOARGS, "Count a fault found before the tick (a malformed p)."},
    {"reset", (PyCFunction)Renderer_reset, METH_NOARGS, "Clear the state, observer sums and counters."},
    {"set_model", (PyCFunction)Renderer_set_model, METH_O,
     "set_model(other)\n--\n\nHand this renderer other's model (another Renderer core of its dimension: its texture, "
     "algorithm and parameters) for the next tick, which takes it before it computes, the algorithm's state cleared "
     "(hx_render_set_model); other is kept alive while its model may be in use."},
    {"set_stiffness", (PyCFunction)Renderer_set_stiffness, METH_O,
     "set_stiffness(k0): kappa_0 (N/m) for the next tick on, taken between ticks (any thread)."},
    {NULL, NULL, 0, NULL},
};

static PyMemberDef Renderer_members[] = {
    {"faults", T_LONG, offsetof(RendererObject, r.faults), READONLY, "faults counted"},
    {"model_changes", T_LONG, offsetof(RendererObject, r.model_changes), READONLY,
     "models the ticks have taken from set_model"},
    {"stiffness_changes", T_LONG, offsetof(RendererObject, r.k0_changes), READONLY,
     "stiffnesses taken from set_stiffness (between ticks)"},
    {"vibration_clamped", T_LONG, offsetof(RendererObject, r.vib.vs.clamped), READONLY,
     "vibration ticks whose operating point was moved to the model set's hull"},
    {"vibration_supplied", T_DOUBLE, offsetof(RendererObject, r.vib.supplied), READONLY,
     "the vibration's work on the sensed motion so far (J, > 0: supplied to the hand)"},
    {"friction_dissipated", T_DOUBLE, offsetof(RendererObject, r.vib.dissipated), READONLY,
     "the material friction's work on the sensed motion so far, negated (J, > 0: dissipated)"},
    {"vibration_tank", T_DOUBLE, offsetof(RendererObject, r.vib.tank), READONLY,
     "what the vibration's energy budget holds now (J)"},
    {"vibration_cut", T_LONG, offsetof(RendererObject, r.vib.cut), READONLY,
     "ticks whose vibration the energy budget scaled down"},
    {"vibration_force", T_DOUBLE, offsetof(RendererObject, r.vib.force), READONLY,
     "the vibration's force on the last tick (N, along the tangential velocity)"},
    {"clamps", T_LONG, offsetof(RendererObject, r.clamps), READONLY, "forces scaled to max_force"},
    {"last_work", T_LONG, offsetof(RendererObject, r.work), READONLY, "work of the last tick"},
    {"max_work", T_LONG, offsetof(RendererObject, r.max_work), READONLY, "largest work of a tick"},
    {"cut", T_LONG, offsetof(RendererObject, r.cut), READONLY,
     "ticks whose closest-point search its evaluation budget ended (the best point found, not certified)"},
    {"energy", T_DOUBLE, offsetof(RendererObject, r.pc.E), READONLY, "energy absorbed (J)"},
    {"controller_active", T_LONG, offsetof(RendererObject, r.pc.active), READONLY, "ticks the controller damped"},
    {"controller_damping", T_DOUBLE, offsetof(RendererObject, r.pc.alpha), READONLY, "last alpha (N s/m)"},
    {"observer_delay", T_INT, offsetof(RendererObject, r.pc.delay), READONLY,
     "ticks between a force sent and its acting, as the observer pairs them"},
    {"contact", T_INT, offsetof(RendererObject, r.st.contact), READONLY, "the algorithm's contact flag"},
    {NULL, 0, 0, 0, NULL},
};

static PyGetSetDef Renderer_getset[] = {
    {"energy_per_axis", (getter)Renderer_energy_axis, NULL, "E per axis (J)", NULL},
    {"stiffness", (getter)Renderer_get_stiffness, NULL, "kappa_0 the ticks use (N/m)", NULL},
    {"adhesion", (getter)Renderer_adhesion, NULL, "F's adhesion point (x, y) in contact (m), else None", NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

static PyTypeObject RendererType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "haptex.core._ext.Renderer",
    .tp_basicsize = sizeof(RendererObject),
    .tp_dealloc = (destructor)Renderer_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "The C core's servo tick: a model, its state, the safety rules and counters (see haptex.Renderer).",
    .tp_methods = Renderer_methods,
    .tp_members = Renderer_members,
    .tp_getset = Renderer_getset,
    .tp_init = (initproc)Renderer_init,
    .tp_new = PyType_GenericNew,
};

/* ---- Plant: the simulated device (hx_plant) ---- */

static int read_vector(PyObject *o, int dim, double q[3]);

typedef struct {
    PyObject_HEAD
    hx_plant d;
} PlantObject;

/* a float64 array of exactly count numbers into out */
static int copy_doubles(PyObject *o, double *out, Py_ssize_t count, const char *what)
{
    Py_buffer v;
    if (get_doubles(o, &v, 0, -1, what) < 0)
        return -1;
    if (v.len != count * (Py_ssize_t)sizeof(double)) {
        PyErr_Format(PyExc_ValueError, "%s must hold %zd numbers", what, count);
        PyBuffer_Release(&v);
        return -1;
    }
    memcpy(out, v.buf, (size_t)v.len);
    PyBuffer_Release(&v);
    return 0;
}

static int Plant_init(PlantObject *self, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"phi", "K", "C", "s0", "sv", "dim", "delay", "period", "resolution", "max_force",
                             NULL};
    PyObject *phi, *K, *C, *s0, *sv;
    Py_buffer v;
    hx_plant d;
    int m;
    memset(&d, 0, sizeof d);
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "OOOOOiiddd", kwlist, &phi, &K, &C, &s0, &sv, &d.n, &d.delay,
                                     &d.period, &d.resolution, &d.max_force))
        return -1;
    if ((d.n != 2 && d.n != 3) || d.delay < 0 || d.delay > HX_PLANT_MAXDELAY || !(d.period > 0.0) ||
        !(d.resolution >= 0.0) || !(d.max_force > 0.0)) {
        PyErr_SetString(PyExc_ValueError, "plant settings out of range (checked in haptex.backends first)");
        return -1;
    }
    if (get_doubles(phi, &v, 0, 2, "phi") < 0)
        return -1;
    m = (int)v.shape[0];
    if (v.shape[1] != m || (m != 5 * d.n && m != 7 * d.n)) {
        PyBuffer_Release(&v);
        PyErr_SetString(PyExc_ValueError, "phi must be (5 d, 5 d) or (7 d, 7 d)");
        return -1;
    }
    memcpy(d.phi, v.buf, (size_t)m * (size_t)m * sizeof(double));
    PyBuffer_Release(&v);
    d.m = m;
    if (copy_doubles(K, d.K, d.n * d.n, "K") < 0 || copy_doubles(C, d.C, d.n * d.n, "C") < 0 ||
        copy_doubles(s0, d.s0, d.n, "s0") < 0 || copy_doubles(sv, d.sv, d.n, "sv") < 0)
        return -1;
    hx_plant_reset(&d, 0.0);
    self->d = d;
    return 0;
}

static PyObject *Plant_reset(PlantObject *self, PyObject *arg)
{
    double start = PyFloat_AsDouble(arg);
    if (start == -1.0 && PyErr_Occurred())
        return NULL;
    hx_plant_reset(&self->d, start);
    Py_RETURN_NONE;
}

static PyObject *Plant_release(PlantObject *self, PyObject *unused)
{
    (void)unused;
    hx_plant_release(&self->d);
    Py_RETURN_NONE;
}

static PyObject *Plant_read(PlantObject *self, PyObject *unused)
{
    double p[3];
    (void)unused;
    hx_plant_read(&self->d, p);
    return self->d.n == 3 ? Py_BuildValue("(ddd)", p[0], p[1], p[2]) : Py_BuildValue("(dd)", p[0], p[2]);
}

static PyObject *Plant_write(PlantObject *self, PyObject *arg)
{
    double f[3];
    int rc = read_vector(arg, self->d.n, f);
    if (rc == -2)
        return NULL;
    if (rc < 0) {
        PyErr_Format(PyExc_ValueError, "the force must be %d numbers", self->d.n);
        return NULL;
    }
    if (hx_plant_write(&self->d, f) != 0) {
        PyErr_SetString(PyExc_ValueError, "the force or the device's state is not finite");
        return NULL;
    }
    Py_RETURN_NONE;
}

static PyObject *Plant_get_state(PlantObject *self, void *closure)
{
    PyObject *out = PyList_New(self->d.m);
    int i;
    (void)closure;
    if (out == NULL)
        return NULL;
    for (i = 0; i < self->d.m; i++)
        PyList_SET_ITEM(out, i, PyFloat_FromDouble(self->d.x[i]));
    return out;
}

static PyMethodDef Plant_methods[] = {
    {"reset", (PyCFunction)Plant_reset, METH_O, "reset(start): the handle at rest at height start (m), nothing in flight."},
    {"release", (PyCFunction)Plant_release, METH_NOARGS, "No force acting or in flight; the motion kept."},
    {"read", (PyCFunction)Plant_read, METH_NOARGS, "The handle's position as its encoder reads it (m, dim numbers)."},
    {"write", (PyCFunction)Plant_write, METH_O,
     "write(f): hold f (N, dim numbers) over the next period (after the delay) and advance one period."},
    {NULL, NULL, 0, NULL},
};

static PyMemberDef Plant_members[] = {
    {"k", T_LONG, offsetof(PlantObject, d.k), READONLY, "periods advanced"},
    {NULL, 0, 0, 0, NULL},
};

static PyGetSetDef Plant_getset[] = {
    {"state", (getter)Plant_get_state, NULL, "the state [p, v, u, g, r (, p_h, v_h)] (list of floats)", NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

static PyTypeObject PlantType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "haptex.core._ext.Plant",
    .tp_basicsize = sizeof(PlantObject),
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "The simulated device (hx_plant): a preset held by a hand, one exact period a write.",
    .tp_methods = Plant_methods,
    .tp_members = Plant_members,
    .tp_getset = Plant_getset,
    .tp_init = (initproc)Plant_init,
    .tp_new = PyType_GenericNew,
};

/* ---- Servo: the servo loop's safety rules (hx_servo), its trace, the native drivers ---- */


/* OpenHaptics' HD API, as its hdDefines.h and hd.h declare what the native driver calls */
typedef unsigned int hd_uint;
typedef void (*hd_frame_fn)(hd_uint);
typedef void (*hd_getdv_fn)(hd_uint, double *);
typedef void (*hd_setdv_fn)(hd_uint, const double *);
#define HD_CURRENT_POSITION 0x2050
#define HD_CURRENT_FORCE 0x2700
#define HD_CALLBACK_DONE 0
#define HD_CALLBACK_CONTINUE 1

typedef struct {
    PyObject_HEAD
    hx_servo s;
    PyObject *trace[4];  /* the arrays the trace is written into (t, p, f, engaged), or NULL */
    Py_buffer view[4];
    int viewed;
    /* the native driver of OpenHaptics' scheduler: renderer, HD's functions, the run */
    RendererObject *renderer;
    hd_frame_fn hd_begin, hd_end;
    hd_getdv_fn hd_getdv;
    hd_setdv_fn hd_setdv;
    hd_uint hd_handle;
    long n_ticks;
    double t0;
    volatile int stop, done;
    /* what every driver counts beyond hx_servo: tick work and period jitter (hx_ticks) */
    hx_ticks ticks;
    /* the native servo thread (hx_thread) and the device it drives: a Plant, or DHD's functions */
    hx_thread th;
    int threaded;          /* the thread was started and not yet joined */
    PyObject *device;      /* the Plant driven, kept alive while the thread runs */
    int (*dhd_get_position)(double *, double *, double *, char);
    int (*dhd_set_force)(double, double, double, char);
    char dhd_id;
    hx_haply haply; /* an Inverse3 on its serial port (hx_haply.c), driven by the thread */
} ServoObject;

static double monotonic(void) { return hx_now(); }

/* one tick of a Python or callback driver counted: its start and end (s), the previous start */
static void count_tick(ServoObject *self, double begin, double prev, double end)
{
    hx_ticks_count(&self->ticks, end - begin, prev < 0.0 ? -1.0 : fabs(begin - prev - self->s.period));
}

static void Servo_join(ServoObject *self)
{
    if (self->threaded) {
        self->th.stop = 1;
        Py_BEGIN_ALLOW_THREADS
        hx_thread_join(&self->th);
        Py_END_ALLOW_THREADS
        self->threaded = 0;
    }
}

static void Servo_release(ServoObject *self)
{
    int i;
    if (self->viewed)
        for (i = 0; i < 4; i++)
            PyBuffer_Release(&self->view[i]);
    self->viewed = 0;
    for (i = 0; i < 4; i++)
        Py_CLEAR(self->trace[i]);
    self->s.capacity = 0;
}

static void Servo_dealloc(ServoObject *self)
{
    Servo_join(self); /* (never free what a running thread reads) */
    Py_XDECREF(self->device);
    free(self->ticks.work);
    free(self->ticks.jitter);
    Servo_release(self);
    Py_XDECREF(self->renderer);
    Py_TYPE(self)->tp_free((PyObject *)self);
}

static int Servo_init(ServoObject *self, PyObject *args, PyObject *kwds)
{
    static char *kwlist[] = {"dim", "period", "workspace", "max_force", "engage_force", "engage_ticks",
                             "ramp_ticks", "deadline", "realtime", "t", "p", "f", "engaged", NULL};
    hx_servo s;
    PyObject *tr[4] = {Py_None, Py_None, Py_None, Py_None};
    int i, realtime;
    memset(&s, 0, sizeof s);
    if (!PyArg_ParseTupleAndKeywords(args, kwds, "iddddlldp|OOOO", kwlist, &s.dim, &s.period, &s.workspace,
                                     &s.max_force, &s.engage_force, &s.engage_ticks, &s.ramp_ticks, &s.deadline,
                                     &realtime, &tr[0], &tr[1], &tr[2], &tr[3]))
        return -1;
    if ((s.dim != 2 && s.dim != 3) || !(s.period > 0.0) || !(s.workspace > 0.0) || !(s.max_force > 0.0) ||
        !(s.engage_force > 0.0) || s.engage_ticks < 1 || s.ramp_ticks < 1 || !(s.deadline >= 1.0)) {
        PyErr_SetString(PyExc_ValueError, "servo settings out of range (checked in haptex.servo first)");
        return -1;
    }
    if (self->threaded) {
        PyErr_SetString(PyExc_RuntimeError, "the servo's native thread is running: join it first");
        return -1;
    }
    Servo_release(self);
    hx_servo_init(&s);
    s.realtime = realtime;
    if (self->ticks.work == NULL)
        self->ticks.work = malloc((HX_HIST_BINS + 1) * sizeof(unsigned int));
    if (self->ticks.jitter == NULL)
        self->ticks.jitter = malloc((HX_HIST_BINS + 1) * sizeof(unsigned int));
    if (self->ticks.work == NULL || self->ticks.jitter == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    memset(self->ticks.work, 0, (HX_HIST_BINS + 1) * sizeof(unsigned int));
    memset(self->ticks.jitter, 0, (HX_HIST_BINS + 1) * sizeof(unsigned int));
    self->ticks.work_max = self->ticks.jitter_max = 0.0;
    self->ticks.overruns = 0;
    if (tr[0] != Py_None) {
        Py_ssize_t n;
        for (i = 0; i < 3; i++)
            if (get_doubles(tr[i], &self->view[i], 1, i == 0 ? 1 : 2, i == 0 ? "t" : i == 1 ? "p" : "f") < 0) {
                while (--i >= 0)
                    PyBuffer_Release(&self->view[i]);
                return -1;
            }
        if (PyObject_GetBuffer(tr[3], &self->view[3], PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_WRITABLE) < 0) {
            for (i = 0; i < 3; i++)
                PyBuffer_Release(&self->view[i]);
            return -1;
        }
        n = self->view[0].shape[0];
        self->viewed = 1;
        if (self->view[3].itemsize != 1 || self->view[3].ndim != 1 || self->view[3].shape[0] != n ||
            self->view[1].shape[0] != n || self->view[1].shape[1] != s.dim || self->view[2].shape[0] != n ||
            self->view[2].shape[1] != s.dim) {
            Servo_release(self);
            PyErr_SetString(PyExc_ValueError, "the trace must be t (n,), p and f (n, dim) float64, engaged (n,) bool");
            return -1;
        }
        for (i = 0; i < 4; i++) {
            Py_INCREF(tr[i]);
            self->trace[i] = tr[i];
        }
        s.capacity = (long)n;
        s.rec_t = self->view[0].buf;
        s.rec_p = self->view[1].buf;
        s.rec_f = self->view[2].buf;
        s.rec_e = self->view[3].buf;
    }
    self->s = s;
    self->stop = self->done = 0;
    return 0;
}

/* dim coordinates of o into q ([x, y, z], y = 0 in the plane): 0, or -1 when o is not dim real
 * numbers (the error cleared: a fault), or -2 for an error that must propagate (not an
 * Exception: KeyboardInterrupt, SystemExit) */
static int read_vector(PyObject *o, int dim, double q[3])
{
    double v[3] = {0.0, 0.0, 0.0};
    int i;
    if (PyObject_CheckBuffer(o)) {
        Py_buffer b;
        if (PyObject_GetBuffer(o, &b, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) == 0) {
            int ok = b.ndim == 1 && b.shape[0] == dim && b.itemsize == 8 && b.format != NULL &&
                     strcmp(b.format, "d") == 0;
            if (ok)
                memcpy(v, b.buf, (size_t)dim * sizeof(double));
            PyBuffer_Release(&b);
            if (!ok)
                return -1;
            goto done;
        }
        PyErr_Clear();
    }
    {
        PyObject *seq = PySequence_Fast(o, "");
        if (seq == NULL)
            goto failed;
        if (PySequence_Fast_GET_SIZE(seq) != dim) {
            Py_DECREF(seq);
            return -1;
        }
        for (i = 0; i < dim; i++) {
            PyObject *c = PySequence_Fast_GET_ITEM(seq, i);
            if (PyBool_Check(c) || PyComplex_Check(c)) {
                Py_DECREF(seq);
                return -1;
            }
            v[i] = PyFloat_AsDouble(c);
            if (v[i] == -1.0 && PyErr_Occurred()) {
                Py_DECREF(seq);
                goto failed;
            }
        }
        Py_DECREF(seq);
    }
done:
    q[0] = v[0];
    q[1] = dim == 3 ? v[1] : 0.0;
    q[2] = dim == 3 ? v[2] : v[1];
    return 0;
failed:
    if (!PyErr_ExceptionMatches(PyExc_Exception))
        return -2;
    PyErr_Clear();
    return -1;
}

static PyObject *servo_force(const ServoObject *self, const double f[3])
{
    return self->s.dim == 3 ? Py_BuildValue("(ddd)", f[0], f[1], f[2]) : Py_BuildValue("(dd)", f[0], f[2]);
}

PyDoc_STRVAR(servo_tick_doc, "tick(t, p, step)\n--\n\nOne tick under the rules: the sample's time t (s) and "
                             "position p (m, dim numbers), step the renderer (a Renderer core, called in C) or a "
                             "callable p -> force; returns the force to command (N). A failing sample or step is "
                             "a fault (zero force); an error that is not an Exception (Ctrl-C) propagates.");

static PyObject *Servo_tick(ServoObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double t, p[3], f[3] = {0.0, 0.0, 0.0}, prev, begin, end;
    int rc, fault;
    if (nargs != 3) {
        PyErr_SetString(PyExc_TypeError, "tick takes t, p and step");
        return NULL;
    }
    t = PyFloat_AsDouble(args[0]);
    if (t == -1.0 && PyErr_Occurred())
        return NULL;
    prev = self->s.have_wall ? self->s.last_wall : -1.0;
    begin = monotonic();
    hx_servo_begin(&self->s, begin);
    rc = read_vector(args[1], self->s.dim, p);
    if (rc == -2)
        return NULL;
    if (rc < 0)
        p[0] = p[1] = p[2] = NAN;
    fault = rc < 0 || !hx_servo_usable(&self->s, p);
    if (!fault) {
        if (Py_IS_TYPE(args[2], &RendererType)) {
            hx_render_step(&((RendererObject *)args[2])->r, p[0], p[1], p[2], f);
        } else {
            PyObject *out = PyObject_CallOneArg(args[2], args[1]);
            if (out == NULL) {
                if (!PyErr_ExceptionMatches(PyExc_Exception))
                    return NULL;
                PyErr_Clear();
                fault = 1;
            } else {
                rc = read_vector(out, self->s.dim, f);
                Py_DECREF(out);
                if (rc == -2)
                    return NULL;
                fault = rc < 0;
            }
        }
    }
    hx_servo_command(&self->s, t, p, fault, f);
    end = monotonic();
    hx_servo_end(&self->s, end);
    count_tick(self, begin, prev, end);
    return servo_force(self, f);
}

/* OpenHaptics' scheduler calls this once a tick in its servo thread: no Python, no GIL */
static hd_uint hd_servo_callback(void *data)
{
    ServoObject *self = data;
    double pos[3], p[3], f[3] = {0.0, 0.0, 0.0}, fd[3] = {0.0, 0.0, 0.0}, wall, prev, end;
    self->hd_begin(self->hd_handle);
    if (self->stop || self->s.k >= self->n_ticks) {
        self->hd_setdv(HD_CURRENT_FORCE, fd);
        self->hd_end(self->hd_handle);
        self->done = 1;
        return HD_CALLBACK_DONE;
    }
    self->hd_getdv(HD_CURRENT_POSITION, pos);
    /* HD: mm, x right, y up, z towards the user; haptex: m, z up: p = (x, -z, y) / 1000 */
    p[0] = 1e-3 * pos[0];
    p[1] = -1e-3 * pos[2];
    p[2] = 1e-3 * pos[1];
    prev = self->s.have_wall ? self->s.last_wall : -1.0;
    wall = monotonic();
    hx_servo_tick(&self->s, &self->renderer->r, wall, wall - self->t0, p, f);
    fd[0] = f[0];
    fd[1] = f[2];
    fd[2] = -f[1];
    self->hd_setdv(HD_CURRENT_FORCE, fd);
    self->hd_end(self->hd_handle);
    end = monotonic();
    hx_servo_end(&self->s, end);
    count_tick(self, wall, prev, end);
    return HD_CALLBACK_CONTINUE;
}

PyDoc_STRVAR(servo_hd_doc, "hd_callback(renderer, begin, end, getdv, setdv, handle, n_ticks, t0)\n--\n\n"
                           "Bind the native tick to OpenHaptics' HD functions (their addresses, ints) for n_ticks "
                           "ticks of renderer (a Renderer core, 3-D) on device handle, sample times from t0 "
                           "(time.perf_counter's clock, s); returns (callback, data): the addresses to give "
                           "hdScheduleAsynchronous. The callback sends zero force and ends after n_ticks or stop().");

static void *address(PyObject *o)
{
    void *a = PyLong_AsVoidPtr(o);
    if (a == NULL && !PyErr_Occurred())
        PyErr_SetString(PyExc_ValueError, "a function's address must not be 0");
    return a;
}

static PyObject *Servo_hd_callback(ServoObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    void *fn[4];
    int i;
    unsigned long handle;
    long n;
    double t0;
    if (nargs != 8 || !Py_IS_TYPE(args[0], &RendererType) || ((RendererObject *)args[0])->dim != 3 ||
        self->s.dim != 3) {
        PyErr_SetString(PyExc_TypeError, "hd_callback takes a 3-D Renderer core, four addresses, handle, n_ticks, t0");
        return NULL;
    }
    for (i = 0; i < 4; i++)
        if ((fn[i] = address(args[1 + i])) == NULL)
            return NULL;
    handle = PyLong_AsUnsignedLong(args[5]);
    n = PyLong_AsLong(args[6]);
    t0 = PyFloat_AsDouble(args[7]);
    if (PyErr_Occurred())
        return NULL;
    /* (object pointers to function pointers through memcpy: C99 leaves the cast undefined) */
    memcpy(&self->hd_begin, &fn[0], sizeof fn[0]);
    memcpy(&self->hd_end, &fn[1], sizeof fn[1]);
    memcpy(&self->hd_getdv, &fn[2], sizeof fn[2]);
    memcpy(&self->hd_setdv, &fn[3], sizeof fn[3]);
    self->hd_handle = (hd_uint)handle;
    self->n_ticks = n;
    self->t0 = t0;
    self->stop = self->done = 0;
    Py_INCREF(args[0]);
    Py_XSETREF(self->renderer, (RendererObject *)args[0]);
    {
        hd_uint (*cb)(void *) = hd_servo_callback;
        void *cbp;
        memcpy(&cbp, &cb, sizeof cbp);
        return Py_BuildValue("(NN)", PyLong_FromVoidPtr(cbp), PyLong_FromVoidPtr(self));
    }
}

static PyObject *Servo_stop(ServoObject *self, PyObject *unused)
{
    (void)unused;
    self->stop = 1;
    self->th.stop = 1;
    Py_RETURN_NONE;
}

static PyObject *Servo_get_done(ServoObject *self, void *closure)
{
    (void)closure;
    if (self->threaded)
        return PyBool_FromLong(HX_LOAD_ACQ(&self->th.done));
    return PyBool_FromLong(self->done);
}

/* ---- the native servo thread's devices ---- */

static int plant_read(void *ctx, double p[3])
{
    hx_plant_read(ctx, p);
    return 0;
}

static int plant_write(void *ctx, const double f[3]) { return hx_plant_write(ctx, f) != 0; }

/* DHD (Force Dimension's SDK): SI units and haptex's own frame (x towards the user, z up) */
static int dhd_read(void *ctx, double p[3])
{
    ServoObject *self = ctx;
    return self->dhd_get_position(&p[0], &p[1], &p[2], self->dhd_id) < 0;
}

static int dhd_write(void *ctx, const double f[3])
{
    ServoObject *self = ctx;
    return self->dhd_set_force(f[0], f[1], f[2], self->dhd_id) < 0;
}

static const char *haply_error(int rc)
{
    switch (rc) {
    case 0:
        return "";
    case HX_HAPLY_EWRITE:
        return "the port refused a write";
    case HX_HAPLY_EREAD:
        return "the port failed a read";
    case HX_HAPLY_ETIMEOUT:
        return "no answer within the timeout";
    default:
        return "an answer that is not the device's state";
    }
}

PyDoc_STRVAR(servo_start_doc,
             "start(renderer, device, n_ticks, paced, priority, lock_memory, spin, keep_awake)\n--\n\n"
             "Start the native servo thread: n_ticks ticks of renderer (a Renderer core) under the rules, on device: a "
             "Plant (the simulated device), ('dhd', dhdGetPosition's address, dhdSetForce's address, device id) "
             "(3-D) or ('haply', port, timeout): an Inverse3 woken on the serial port haply_open opened, answering each force "
             "command within timeout s (3-D; a first zero-force exchange reads its state before the thread "
             "starts, OSError if it fails). paced: one tick a period on the clock (else as fast as it goes); priority: SCHED_FIFO priority "
             "to ask for (0: none); lock_memory: mlockall for the run where allowed; spin (s): sleep until this long "
             "before a tick, then read the clock; keep_awake: pin the thread to one core and keep that core from halting with a "
             "spinning companion below it (Linux, 2 cores or more). Returns at once; the thread "
             "sends zero force at its end, on stop(), or when the device fails. join() waits for it.");

static PyObject *Servo_start(ServoObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    RendererObject *r;
    long n;
    int paced, priority, lock, awake, rc;
    double spin;
    if (nargs != 8 || !Py_IS_TYPE(args[0], &RendererType)) {
        PyErr_SetString(PyExc_TypeError,
                        "start takes a Renderer core, a device, n_ticks, paced, priority, lock_memory, spin, keep_awake");
        return NULL;
    }
    if (self->threaded) {
        PyErr_SetString(PyExc_RuntimeError, "the servo's native thread is running: join it first");
        return NULL;
    }
    r = (RendererObject *)args[0];
    n = PyLong_AsLong(args[2]);
    paced = PyObject_IsTrue(args[3]);
    priority = (int)PyLong_AsLong(args[4]);
    lock = PyObject_IsTrue(args[5]);
    spin = PyFloat_AsDouble(args[6]);
    awake = PyObject_IsTrue(args[7]);
    if (PyErr_Occurred() || awake < 0)
        return NULL;
    if (n < 0 || priority < 0 || priority > 99 || r->dim != self->s.dim || !(spin >= 0.0 && spin <= 0.01)) {
        PyErr_SetString(PyExc_ValueError,
                        "n_ticks >= 0, priority 0-99, spin 0-10 ms and a renderer of the servo's dimension");
        return NULL;
    }
    memset(&self->th, 0, sizeof self->th);
    if (Py_IS_TYPE(args[1], &PlantType)) {
        hx_plant *d = &((PlantObject *)args[1])->d;
        if (d->n != self->s.dim) {
            PyErr_SetString(PyExc_ValueError, "the plant's dimension is not the servo's");
            return NULL;
        }
        self->th.io.read = plant_read;
        self->th.io.write = plant_write;
        self->th.io.ctx = d;
    } else if (PyTuple_Check(args[1]) && PyTuple_GET_SIZE(args[1]) == 4 && self->s.dim == 3 &&
               PyUnicode_Check(PyTuple_GET_ITEM(args[1], 0)) &&
               PyUnicode_CompareWithASCIIString(PyTuple_GET_ITEM(args[1], 0), "dhd") == 0) {
        void *g = address(PyTuple_GET_ITEM(args[1], 1)), *f;
        long id;
        if (g == NULL || (f = address(PyTuple_GET_ITEM(args[1], 2))) == NULL)
            return NULL;
        id = PyLong_AsLong(PyTuple_GET_ITEM(args[1], 3));
        if (id == -1 && PyErr_Occurred())
            return NULL;
        memcpy(&self->dhd_get_position, &g, sizeof g);
        memcpy(&self->dhd_set_force, &f, sizeof f);
        self->dhd_id = (char)id;
        self->th.io.read = dhd_read;
        self->th.io.write = dhd_write;
        self->th.io.ctx = self;
    } else if (PyTuple_Check(args[1]) && PyTuple_GET_SIZE(args[1]) == 3 && self->s.dim == 3 &&
               PyUnicode_Check(PyTuple_GET_ITEM(args[1], 0)) &&
               PyUnicode_CompareWithASCIIString(PyTuple_GET_ITEM(args[1], 0), "haply") == 0) {
        const double zero[3] = {0.0, 0.0, 0.0};
        Py_ssize_t fd = PyLong_AsSsize_t(PyTuple_GET_ITEM(args[1], 1));
        double timeout = PyFloat_AsDouble(PyTuple_GET_ITEM(args[1], 2));
        int xrc;
        if (PyErr_Occurred())
            return NULL;
        if (fd < 0 || !(timeout > 0.0 && timeout <= 1.0)) {
            PyErr_SetString(PyExc_ValueError, "haply: a port (haply_open's) >= 0 and a timeout in (0, 1] s");
            return NULL;
        }
        memset(&self->haply, 0, sizeof self->haply);
        self->haply.fd = (intptr_t)fd;
        self->haply.timeout = timeout;
        Py_BEGIN_ALLOW_THREADS
        xrc = hx_haply_exchange(&self->haply, zero);
        Py_END_ALLOW_THREADS
        if (xrc != 0)
            return PyErr_Format(PyExc_OSError, "haply: the first zero-force exchange failed (%s)", haply_error(xrc));
        self->th.io.read = hx_haply_read;
        self->th.io.write = hx_haply_write;
        self->th.io.ctx = &self->haply;
    } else {
        PyErr_SetString(PyExc_TypeError,
                        "device must be a Plant, ('dhd', get_position, set_force, id) or ('haply', port, timeout) (3-D)");
        return NULL;
    }
    self->th.servo = &self->s;
    self->th.renderer = &r->r;
    self->th.ticks = &self->ticks;
    self->th.n_ticks = n;
    self->th.paced = paced;
    self->th.priority = priority;
    self->th.lock_memory = lock;
    self->th.keep_awake = awake;
    self->th.spin = fmin(spin, 0.5 * self->s.period); /* (never a spin all period long: a FIFO spin starves the core) */
    Py_INCREF(args[0]);
    Py_XSETREF(self->renderer, r);
    Py_INCREF(args[1]);
    Py_XSETREF(self->device, args[1]);
    self->stop = 0;
    rc = hx_thread_start(&self->th);
    if (rc != 0) {
        errno = rc;
        return PyErr_SetFromErrno(PyExc_OSError);
    }
    self->threaded = 1;
    Py_RETURN_NONE;
}

static PyObject *Servo_join_method(ServoObject *self, PyObject *unused)
{
    (void)unused;
    if (self->threaded) {
        Py_BEGIN_ALLOW_THREADS
        hx_thread_join(&self->th);
        Py_END_ALLOW_THREADS
        self->threaded = 0;
    }
    Py_RETURN_NONE;
}

static PyObject *Servo_snapshot(ServoObject *self, PyObject *unused)
{
    hx_snapshot sn;
    (void)unused;
    hx_thread_snapshot(&self->th, &sn);
    return Py_BuildValue("(ld(ddd)(ddd))", sn.k, sn.t, sn.p[0], sn.p[1], sn.p[2], sn.f[0], sn.f[1], sn.f[2]);
}

PyDoc_STRVAR(servo_timing_doc, "timing()\n--\n\nThe ticks' timing as counted by every driver: a dict of work_max, "
                               "work_p999, jitter_max, jitter_p999 (s; jitter |dt - T|, dt the time between samples; "
                               "quantiles to 100 ns), overruns; and for the native thread fifo, locked, awake (what it got; awake: "
                               "the core kept awake, its number + 1, or 0) "
                               "and io_error (0, 1 the device's read failed, 2 its write) at io_error_tick; device_error: an Inverse3's "
                               "failure in words ('' for none or another device).");

static PyObject *Servo_timing(ServoObject *self, PyObject *unused)
{
    (void)unused;
    return Py_BuildValue("{s:d,s:d,s:d,s:d,s:l,s:O,s:O,s:i,s:i,s:l,s:s}", "work_max", self->ticks.work_max, "work_p999",
                         fmin(hx_ticks_quantile(self->ticks.work, 0.999), self->ticks.work_max), "jitter_max",
                         self->ticks.jitter_max, "jitter_p999",
                         fmin(hx_ticks_quantile(self->ticks.jitter, 0.999), self->ticks.jitter_max), "overruns",
                         self->ticks.overruns, "fifo", self->th.fifo ? Py_True : Py_False, "locked",
                         self->th.locked ? Py_True : Py_False, "awake", self->th.awake, "io_error", self->th.io_error,
                         "io_error_tick",
                         self->th.io_error_tick, "device_error", haply_error(self->haply.error));
}

static PyObject *Servo_get_engaged_at(ServoObject *self, void *closure)
{
    (void)closure;
    if (self->s.engaged_at < 0)
        Py_RETURN_NONE;
    return PyLong_FromLong(self->s.engaged_at);
}

static PyObject *Servo_get_period_std(ServoObject *self, void *closure)
{
    (void)closure;
    return PyFloat_FromDouble(self->s.periods > 0 ? sqrt(self->s.period_m2 / (double)self->s.periods) : 0.0);
}

static PyObject *Servo_get_work_mean(ServoObject *self, void *closure)
{
    (void)closure;
    return PyFloat_FromDouble(self->s.k > 0 ? self->s.work_sum / (double)self->s.k : 0.0);
}

static PyMethodDef Servo_methods[] = {
    {"tick", (PyCFunction)(void (*)(void))Servo_tick, METH_FASTCALL, servo_tick_doc},
    {"hd_callback", (PyCFunction)(void (*)(void))Servo_hd_callback, METH_FASTCALL, servo_hd_doc},
    {"stop", (PyCFunction)Servo_stop, METH_NOARGS, "Ask the native driver (callback or thread) to send zero and end."},
    {"start", (PyCFunction)(void (*)(void))Servo_start, METH_FASTCALL, servo_start_doc},
    {"join", (PyCFunction)Servo_join_method, METH_NOARGS, "Wait for the native thread's end (the GIL released)."},
    {"snapshot", (PyCFunction)Servo_snapshot, METH_NOARGS,
     "The native thread's last tick, read without blocking it (a seqlock): (k, t, p, f)."},
    {"timing", (PyCFunction)Servo_timing, METH_NOARGS, servo_timing_doc},
    {NULL, NULL, 0, NULL},
};

static PyMemberDef Servo_members[] = {
    {"ticks", T_LONG, offsetof(ServoObject, s.k), READONLY, "ticks commanded"},
    {"stopping", T_INT, offsetof(ServoObject, stop), READONLY, "stop() was asked (every driver ends at it)"},
    {"missed", T_LONG, offsetof(ServoObject, s.missed), READONLY, "late samples (answered with zero force)"},
    {"faults", T_LONG, offsetof(ServoObject, s.faults), READONLY, "ticks answered with zero for a fault"},
    {"clamps", T_LONG, offsetof(ServoObject, s.clamps), READONLY, "forces the loop scaled to its maximum"},
    {"max_force_sent", T_DOUBLE, offsetof(ServoObject, s.max_sent), READONLY, "largest force commanded (N)"},
    {"work_max", T_DOUBLE, offsetof(ServoObject, s.work_max), READONLY, "longest tick, sample to command (s)"},
    {"period_mean", T_DOUBLE, offsetof(ServoObject, s.period_mean), READONLY, "mean time between samples (s)"},
    {"periods", T_LONG, offsetof(ServoObject, s.periods), READONLY, "periods measured"},
    {NULL, 0, 0, 0, NULL},
};

static PyGetSetDef Servo_getset[] = {
    {"done", (getter)Servo_get_done, NULL, "the native driver's callback has ended", NULL},
    {"engaged_at", (getter)Servo_get_engaged_at, NULL, "the tick forces engaged at, or None", NULL},
    {"period_std", (getter)Servo_get_period_std, NULL, "standard deviation of the time between samples (s)", NULL},
    {"work_mean", (getter)Servo_get_work_mean, NULL, "mean time of a tick, sample to command (s)", NULL},
    {NULL, NULL, NULL, NULL, NULL},
};

static PyTypeObject ServoType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "haptex.core._ext.Servo",
    .tp_basicsize = sizeof(ServoObject),
    .tp_dealloc = (destructor)Servo_dealloc,
    .tp_flags = Py_TPFLAGS_DEFAULT,
    .tp_doc = "The servo loop's safety rules (hx_servo), its trace and native drivers (see haptex.servo).",
    .tp_methods = Servo_methods,
    .tp_members = Servo_members,
    .tp_getset = Servo_getset,
    .tp_init = (initproc)Servo_init,
    .tp_new = PyType_GenericNew,
};

/* Run r's model from a batch's buffers: prm (N, HX_N_PARAMS), coeffs (N, rows, cols), aux (N, k). */
static void batch_model(hx_model *m, int code, int kind, const Py_buffer *prm, const Py_buffer *coeffs,
                        const Py_buffer *aux, Py_ssize_t r)
{
    long rows = (long)coeffs->shape[1], cols = (long)coeffs->shape[2], i;
    m->code = code;
    m->base = NULL;
    for (i = 0; i < HX_N_PARAMS; i++)
        m->prm[i] = ((const double *)prm->buf)[r * HX_N_PARAMS + i];
    m->tex.kind = kind;
    m->tex.c = (const double *)coeffs->buf + r * rows * cols;
    m->tex.rows = rows;
    m->tex.cols = cols;
    m->aux = (const double *)aux->buf + r * aux->shape[1];
    m->naux = (long)aux->shape[1];
}

PyDoc_STRVAR(run_lean_doc,
"run_lean(code, kind, nominal, n_steps, period, record_every, tail_start, prm, coeffs, aux, fast, mass, f0,\n"
"         p0, v0, rec, summary, tail)\n--\n\n"
"The simulator's lean loop (hx_run_lean) for N runs, with the GIL released. Per-run arrays have a leading\n"
"N axis: prm (N, 6), coeffs (N, rows, cols), aux (N, k), fast (N, 2, n, 7), mass (N, n, n), f0, p0, v0\n"
"(N, n), rec (N, n_rec, 4n + 4), summary (N, 16), tail (N, n, n_tail); n = 2 or 3.");

static PyObject *run_lean(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    static const int ndims[11] = {2, 3, 2, 4, 3, 2, 2, 2, 3, 2, 3};
    static const char *names[11] = {"prm", "coeffs", "aux", "fast", "mass", "f0", "p0", "v0", "rec", "summary",
                                    "tail"};
    Py_buffer b[11];
    int code, kind, nominal, got = 0, i, rc = HX_OK, dim;
    long n_steps, record_every, tail_start;
    double period;
    Py_ssize_t N, r;
    (void)self;
    if (nargs != 18) {
        PyErr_SetString(PyExc_TypeError, "run_lean takes 18 arguments");
        return NULL;
    }
    code = (int)PyLong_AsLong(args[0]);
    kind = (int)PyLong_AsLong(args[1]);
    nominal = PyObject_IsTrue(args[2]);
    n_steps = PyLong_AsLong(args[3]);
    period = PyFloat_AsDouble(args[4]);
    record_every = PyLong_AsLong(args[5]);
    tail_start = PyLong_AsLong(args[6]);
    if (PyErr_Occurred())
        return NULL;
    for (got = 0; got < 11; got++)
        if (get_doubles(args[7 + got], &b[got], got >= 8, ndims[got], names[got]) < 0)
            goto done;
    N = b[0].shape[0];
    dim = (int)b[5].shape[1];
    for (i = 0; i < 11; i++) {
        if (b[i].shape[0] != N) {
            PyErr_Format(PyExc_ValueError, "%s must have %zd runs", names[i], N);
            goto done;
        }
    }
    if ((dim != 2 && dim != 3) || b[0].shape[1] != HX_N_PARAMS || b[3].shape[1] != 2 || b[3].shape[2] != dim ||
        b[3].shape[3] != HX_N_FAST || b[4].shape[1] != dim || b[4].shape[2] != dim || b[6].shape[1] != dim ||
        b[7].shape[1] != dim || b[8].shape[2] != 4 * dim + 4 || b[9].shape[1] != HX_N_SUMMARY ||
        b[10].shape[1] != dim || n_steps < 0 || record_every < 1 || tail_start < 0 || !(period > 0.0)) {
        PyErr_SetString(PyExc_ValueError, "run_lean: arrays of inconsistent shapes or invalid counts");
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS
    for (r = 0; r < N && rc == HX_OK; r++) {
        hx_model m;
        hx_lean_run run;
        long n_rec = (long)b[8].shape[1];
        batch_model(&m, code, kind, &b[0], &b[1], &b[2], r);
        run.dim = dim;
        run.nominal = nominal;
        run.fast = (const double *)b[3].buf + r * 2 * dim * HX_N_FAST;
        run.mass = (const double *)b[4].buf + r * dim * dim;
        run.f0 = (const double *)b[5].buf + r * dim;
        run.p0 = (const double *)b[6].buf + r * dim;
        run.v0 = (const double *)b[7].buf + r * dim;
        run.n_steps = n_steps;
        run.period = period;
        run.record_every = record_every;
        run.n_rec = n_rec;
        run.rec = (double *)b[8].buf + r * n_rec * (4 * dim + 4);
        run.summary = (double *)b[9].buf + r * HX_N_SUMMARY;
        run.tail_start = tail_start;
        run.n_tail = (long)b[10].shape[2];
        run.tail = (double *)b[10].buf + r * dim * run.n_tail;
        rc = hx_run_lean(&m, &run);
    }
    Py_END_ALLOW_THREADS
    if (rc != HX_OK)
        core_error(rc);
done:
    for (i = 0; i < got; i++)
        PyBuffer_Release(&b[i]);
    if (PyErr_Occurred())
        return NULL;
    Py_RETURN_NONE;
}

/* an 8-byte signed integer's buffer format ("l" on LP64, "q" elsewhere) */
static int is_int64(const char *format)
{
    return format != NULL && (strcmp(format, "q") == 0 || strcmp(format, "l") == 0);
}

/* A profile's texture and search data from args (kind, coeffs, aux), both checked (aux: the
 * search data a closest-point search reads, hx_closest_aux_check); the buffers stay held.
 * aux NULL: (kind, coeffs) only. */
static int get_profile(PyObject *const *args, Py_buffer *coeffs, Py_buffer *aux, hx_texture *tex, const char *fn)
{
    long kind = PyLong_AsLong(args[0]);
    int rc;
    if (kind == -1 && PyErr_Occurred())
        return -1;
    if (kind != HX_TEXTURE_FLAT && kind != HX_TEXTURE_FOURIER && kind != HX_TEXTURE_SPLINE) {
        PyErr_Format(PyExc_ValueError, "%s: kind must be a profile's", fn);
        return -1;
    }
    if (get_doubles(args[1], coeffs, 0, -1, "coeffs") < 0)
        return -1;
    if (aux != NULL && get_doubles(args[2], aux, 0, 1, "aux") < 0) {
        PyBuffer_Release(coeffs);
        return -1;
    }
    rc = texture_over(tex, kind, coeffs);
    if (rc == HX_OK)
        rc = hx_texture_check(tex->kind, tex->c, tex->rows, tex->cols);
    if (rc == HX_OK && aux != NULL)
        rc = hx_closest_aux_check((const double *)aux->buf, (long)aux->shape[0]);
    if (rc != HX_OK) {
        if (aux != NULL)
            PyBuffer_Release(aux);
        PyBuffer_Release(coeffs);
        core_error(rc);
        return -1;
    }
    return 0;
}

PyDoc_STRVAR(closest_profile_doc,
"closest_profile(kind, coeffs, aux, px, pz, t, distance, tie, work)\n--\n\n"
"The closest point of a profile's boundary (hx_closest_profile) to each probe (px, pz) (float64 (N,), m),\n"
"into t, distance (float64 (N,), m), tie and work (int64 (N,)); no warm start. The GIL is released.");

static PyObject *closest_profile(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer coeffs, aux, px, pz, t, d, tie, work;
    hx_texture tex;
    Py_ssize_t i, n;
    (void)self;
    if (nargs != 9) {
        PyErr_SetString(PyExc_TypeError, "closest_profile takes 9 arguments");
        return NULL;
    }
    if (get_profile(args, &coeffs, &aux, &tex, "closest_profile") < 0)
        return NULL;
    if (get_doubles(args[3], &px, 0, 1, "px") < 0)
        goto fail2;
    if (get_doubles(args[4], &pz, 0, 1, "pz") < 0)
        goto fail3;
    if (get_doubles(args[5], &t, 1, 1, "t") < 0)
        goto fail4;
    if (get_doubles(args[6], &d, 1, 1, "distance") < 0)
        goto fail5;
    if (PyObject_GetBuffer(args[7], &tie, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_WRITABLE) < 0)
        goto fail6;
    if (PyObject_GetBuffer(args[8], &work, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_WRITABLE) < 0)
        goto fail7;
    n = px.shape[0];
    if (tie.itemsize != 8 || work.itemsize != 8 || tie.ndim != 1 || work.ndim != 1 || !is_int64(tie.format) ||
        !is_int64(work.format) || pz.shape[0] != n || t.shape[0] != n || d.shape[0] != n || tie.shape[0] != n ||
        work.shape[0] != n) {
        PyErr_SetString(PyExc_ValueError, "closest_profile: px, pz, t, distance (float64) and tie, work (int64) "
                                          "must all have N values");
        goto fail8;
    }
    Py_BEGIN_ALLOW_THREADS
    for (i = 0; i < n; i++) {
        double x = ((const double *)px.buf)[i], z = ((const double *)pz.buf)[i];
        hx_closest c = hx_closest_profile(&tex, (const double *)aux.buf, x, z, hx_texture_height(&tex, x, 0.0) - z,
                                          NAN);
        ((double *)t.buf)[i] = c.t;
        ((double *)d.buf)[i] = c.distance;
        ((long long *)tie.buf)[i] = c.tie;
        ((long long *)work.buf)[i] = c.work;
    }
    Py_END_ALLOW_THREADS
fail8:
    PyBuffer_Release(&work);
fail7:
    PyBuffer_Release(&tie);
fail6:
    PyBuffer_Release(&d);
fail5:
    PyBuffer_Release(&t);
fail4:
    PyBuffer_Release(&pz);
fail3:
    PyBuffer_Release(&px);
fail2:
    PyBuffer_Release(&aux);
    PyBuffer_Release(&coeffs);
    if (PyErr_Occurred())
        return NULL;
    Py_RETURN_NONE;
}

PyDoc_STRVAR(leaf_bounds_doc,
"leaf_bounds(kind, coeffs, start, width, n_sub, jerk, lo, hi)\n--\n\n"
"Bounds of a profile h over len(lo) leaves of `width` (m) from `start` (hx_leaf_bounds), each sampled\n"
"at n_sub + 1 points, jerk bounding the third derivative, into lo and hi (float64 (n,), m). Returns\n"
"(t, h) of the lowest height found. The GIL is released.");

static PyObject *leaf_bounds(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer coeffs, lo, hi;
    hx_texture tex;
    double start, width, jerk, t = 0.0, h = 0.0;
    long n_sub;
    (void)self;
    if (nargs != 8) {
        PyErr_SetString(PyExc_TypeError, "leaf_bounds takes 8 arguments");
        return NULL;
    }
    start = PyFloat_AsDouble(args[2]);
    width = PyFloat_AsDouble(args[3]);
    n_sub = PyLong_AsLong(args[4]);
    jerk = PyFloat_AsDouble(args[5]);
    if (PyErr_Occurred())
        return NULL;
    if (!(isfinite(start) && width > 0.0 && isfinite(width) && n_sub >= 1 && n_sub <= 4096 && jerk >= 0.0)) {
        PyErr_SetString(PyExc_ValueError, "leaf_bounds: start finite, width > 0, 1 <= n_sub <= 4096, jerk >= 0");
        return NULL;
    }
    if (get_profile(args, &coeffs, NULL, &tex, "leaf_bounds") < 0)
        return NULL;
    if (get_doubles(args[6], &lo, 1, 1, "lo") < 0)
        goto fail2;
    if (get_doubles(args[7], &hi, 1, 1, "hi") < 0)
        goto fail3;
    if (hi.shape[0] != lo.shape[0]) {
        PyErr_SetString(PyExc_ValueError, "leaf_bounds: lo and hi must have the same length");
        goto fail4;
    }
    Py_BEGIN_ALLOW_THREADS
    t = hx_leaf_bounds(&tex, start, width, (long)lo.shape[0], n_sub, jerk, (double *)lo.buf, (double *)hi.buf, &h);
    Py_END_ALLOW_THREADS
fail4:
    PyBuffer_Release(&hi);
fail3:
    PyBuffer_Release(&lo);
fail2:
    PyBuffer_Release(&coeffs);
    if (PyErr_Occurred())
        return NULL;
    return Py_BuildValue("dd", t, h);
}

PyDoc_STRVAR(table_cells_doc,
"table_cells(kind, coeffs, aux, x0, w, i0, zlo, hmax, count, out)\n--\n\n"
"Cells i0 .. i0 + len(count) - 1 of one row [zlo, zlo + w] of a periodic profile's cell table\n"
"(hx_table_cell; aux its search data without a table, cell i spanning x0 + [i, i + 1] w): count\n"
"(float64 (n,)) their numbers of pieces (-1: more than TABLE_MAXP; 0 for a row above hmax) and out\n"
"(float64 (n, PIECE * TABLE_MAXP)) the pieces. The GIL is released.");

static PyObject *table_cells(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer coeffs, aux, count, out;
    hx_texture tex;
    double x0, w, zlo, hmax;
    long i0;
    Py_ssize_t k, n;
    (void)self;
    if (nargs != 10) {
        PyErr_SetString(PyExc_TypeError, "table_cells takes 10 arguments");
        return NULL;
    }
    x0 = PyFloat_AsDouble(args[3]);
    w = PyFloat_AsDouble(args[4]);
    i0 = PyLong_AsLong(args[5]);
    zlo = PyFloat_AsDouble(args[6]);
    hmax = PyFloat_AsDouble(args[7]);
    if (PyErr_Occurred())
        return NULL;
    if (!(isfinite(x0) && w > 0.0 && isfinite(w) && i0 >= 0 && isfinite(zlo) && isfinite(hmax))) {
        PyErr_SetString(PyExc_ValueError, "table_cells: x0, zlo, hmax finite, w > 0, i0 >= 0");
        return NULL;
    }
    if (get_profile(args, &coeffs, &aux, &tex, "table_cells") < 0)
        return NULL;
    if (((const double *)aux.buf)[HX_A_MODE] != HX_CP_PERIODIC || ((const double *)aux.buf)[HX_A_TABLE] != 0.0) {
        PyErr_SetString(PyExc_ValueError, "table_cells: aux must be a periodic profile's search data without a table");
        goto fail2;
    }
    if (get_doubles(args[8], &count, 1, 1, "count") < 0)
        goto fail2;
    if (get_doubles(args[9], &out, 1, 2, "out") < 0)
        goto fail3;
    n = count.shape[0];
    if (out.shape[0] != n || out.shape[1] != HX_PIECE * HX_TABLE_MAXP) {
        PyErr_SetString(PyExc_ValueError, "table_cells: out must be (len(count), PIECE * TABLE_MAXP)");
        goto fail4;
    }
    Py_BEGIN_ALLOW_THREADS
    for (k = 0; k < n; k++) {
        double *c = (double *)count.buf + k;
        if (zlo > hmax) { /* every probe of the cell is above the boundary */
            *c = 0.0;
            continue;
        }
        {
            long np = hx_table_cell(&tex, (const double *)aux.buf, x0, w, x0 + ((double)(i0 + k) + 0.5) * w, zlo,
                                    zlo + w, (double *)out.buf + (Py_ssize_t)(HX_PIECE * HX_TABLE_MAXP) * k);
            *c = np <= HX_TABLE_MAXP ? (double)np : -1.0;
        }
    }
    Py_END_ALLOW_THREADS
fail4:
    PyBuffer_Release(&out);
fail3:
    PyBuffer_Release(&count);
fail2:
    PyBuffer_Release(&aux);
    PyBuffer_Release(&coeffs);
    if (PyErr_Occurred())
        return NULL;
    Py_RETURN_NONE;
}

PyDoc_STRVAR(closest_surface_doc,
"closest_surface(kind, coeffs, aux, px, py, pz, tx, ty, distance, tie, work)\n--\n\n"
"The closest point of a surface (hx_closest_surface) to each probe (float64 (N,), m), into tx, ty,\n"
"distance (float64 (N,), m), tie and work (int64 (N,)); no warm start. The GIL is released.");

static PyObject *closest_surface(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer b[10];
    static const char *names[10] = {"coeffs", "aux", "px", "py", "pz", "tx", "ty", "distance", "tie", "work"};
    hx_texture tex;
    long kind;
    int got, rc, i;
    Py_ssize_t k, n;
    (void)self;
    if (nargs != 11) {
        PyErr_SetString(PyExc_TypeError, "closest_surface takes 11 arguments");
        return NULL;
    }
    kind = PyLong_AsLong(args[0]);
    if (kind == -1 && PyErr_Occurred())
        return NULL;
    if (kind != HX_SURFACE_GRATINGS && kind != HX_SURFACE_PATCHES) {
        PyErr_SetString(PyExc_ValueError, "closest_surface: kind must be a surface's");
        return NULL;
    }
    for (got = 0; got < 10; got++) {
        int ok;
        if (got < 8) {
            ok = get_doubles(args[1 + got], &b[got], got >= 5, got == 0 ? -1 : 1, names[got]) == 0;
        } else {
            ok = PyObject_GetBuffer(args[1 + got], &b[got], PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_WRITABLE) == 0;
            if (ok && (b[got].itemsize != 8 || b[got].ndim != 1 || !is_int64(b[got].format))) {
                PyBuffer_Release(&b[got]);
                PyErr_Format(PyExc_ValueError, "%s must be a C-contiguous int64 array", names[got]);
                ok = 0;
            }
        }
        if (!ok)
            goto done;
    }
    rc = texture_of(&tex, kind, args[1], &b[0]);
    if (rc == HX_OK)
        rc = hx_surface_aux_check((const double *)b[1].buf, (long)b[1].shape[0]);
    if (rc != HX_OK) {
        core_error(rc);
        goto done;
    }
    n = b[2].shape[0];
    for (i = 3; i < 10; i++) {
        if (b[i].shape[0] != n) {
            PyErr_SetString(PyExc_ValueError, "closest_surface: every probe array must have N values");
            goto done;
        }
    }
    Py_BEGIN_ALLOW_THREADS
    for (k = 0; k < n; k++) {
        hx_closest c = hx_closest_surface(&tex, (const double *)b[1].buf, ((const double *)b[2].buf)[k],
                                          ((const double *)b[3].buf)[k], ((const double *)b[4].buf)[k], NAN, NAN);
        ((double *)b[5].buf)[k] = c.t;
        ((double *)b[6].buf)[k] = c.y;
        ((double *)b[7].buf)[k] = c.distance;
        ((long long *)b[8].buf)[k] = c.tie;
        ((long long *)b[9].buf)[k] = c.work;
    }
    Py_END_ALLOW_THREADS
done:
    for (i = 0; i < got; i++)
        PyBuffer_Release(&b[i]);
    if (PyErr_Occurred())
        return NULL;
    Py_RETURN_NONE;
}

PyDoc_STRVAR(contact_ascent_doc,
"contact_ascent(kind, coeffs, P, u, lo, hi, g, r, rim, tol, steps)\n--\n\n"
"Each ball contact refined (hx_contact_ascent): the safeguarded Newton ascent of\n"
"H(P + u) + sqrt(r^2 - |u|^2) from offsets u (float64 (N, 2), m, in place) within the boxes\n"
"[lo, hi] (N, 2) and the disc |u| <= rim, its maximum into g (N,); r, rim, tol (m), at most\n"
"steps Newton steps. The GIL is released.");

static PyObject *contact_ascent(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer b[6];
    static const char *names[6] = {"coeffs", "P", "u", "lo", "hi", "g"};
    hx_texture tex;
    long kind, steps;
    double r, rim, tol;
    int got, rc, i;
    Py_ssize_t n;
    (void)self;
    if (nargs != 11) {
        PyErr_SetString(PyExc_TypeError, "contact_ascent takes 11 arguments");
        return NULL;
    }
    kind = PyLong_AsLong(args[0]);
    if (kind == -1 && PyErr_Occurred())
        return NULL;
    r = PyFloat_AsDouble(args[7]);
    rim = PyFloat_AsDouble(args[8]);
    tol = PyFloat_AsDouble(args[9]);
    steps = PyLong_AsLong(args[10]);
    if (PyErr_Occurred())
        return NULL;
    if (!(r > 0.0) || !(rim > 0.0) || !(rim <= r) || !(tol >= 0.0) || steps < 0 || steps > 1000) {
        PyErr_SetString(PyExc_ValueError, "contact_ascent: need r > 0, 0 < rim <= r, tol >= 0, 0 <= steps <= 1000");
        return NULL;
    }
    for (got = 0; got < 6; got++) {
        if (get_doubles(args[1 + got], &b[got], got == 2 || got == 5, got == 0 ? -1 : (got == 5 ? 1 : 2),
                        names[got]) != 0)
            goto done;
    }
    rc = texture_of(&tex, kind, args[1], &b[0]);
    if (rc != HX_OK) {
        core_error(rc);
        goto done;
    }
    n = b[1].shape[0];
    for (i = 1; i < 6; i++) {
        if (b[i].shape[0] != n || (i < 5 && b[i].shape[1] != 2)) {
            PyErr_SetString(PyExc_ValueError, "contact_ascent: P, u, lo and hi must be (N, 2) and g (N,)");
            goto done;
        }
    }
    Py_BEGIN_ALLOW_THREADS
    hx_contact_ascent(&tex, (long)n, (const double *)b[1].buf, (double *)b[2].buf, (const double *)b[3].buf,
                      (const double *)b[4].buf, r, rim, tol, (int)steps, (double *)b[5].buf);
    Py_END_ALLOW_THREADS
done:
    for (i = 0; i < got; i++)
        PyBuffer_Release(&b[i]);
    if (PyErr_Occurred())
        return NULL;
    Py_RETURN_NONE;
}

PyDoc_STRVAR(grid_dilation_doc,
"grid_dilation(hp, offs, lift, half0, half1, best, which)\n--\n\n"
"The grid dilation by a ball's cap (hx_grid_dilation): for each sample of best (float64 (n0, n1)) the\n"
"largest hp[sample + offset] + lift[k] over the offsets offs (int64 (k, 2), grid steps within [-half0,\n"
"half0] x [-half1, half1]) of the heights hp (float64 (n0 + 2 half0, n1 + 2 half1): padded), and in which\n"
"(int32 (n0, n1)) the first offset's index that reaches it. The GIL is released.");

static PyObject *grid_dilation(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer hp, offs, lift, best, which;
    long half0, half1;
    Py_ssize_t k, n0, n1, n_off;
    int ok = 0;
    (void)self;
    if (nargs != 7) {
        PyErr_SetString(PyExc_TypeError, "grid_dilation takes 7 arguments");
        return NULL;
    }
    half0 = PyLong_AsLong(args[3]);
    half1 = PyLong_AsLong(args[4]);
    if (PyErr_Occurred())
        return NULL;
    if (get_doubles(args[0], &hp, 0, 2, "hp") < 0)
        return NULL;
    if (PyObject_GetBuffer(args[1], &offs, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0)
        goto fail_hp;
    if (offs.itemsize != 8 || offs.ndim != 2 || !is_int64(offs.format) || offs.shape[1] != 2) {
        PyErr_SetString(PyExc_ValueError, "offs must be a C-contiguous int64 array (k, 2)");
        goto fail_offs;
    }
    if (get_doubles(args[2], &lift, 0, 1, "lift") < 0)
        goto fail_offs;
    if (get_doubles(args[5], &best, 1, 2, "best") < 0)
        goto fail_lift;
    if (PyObject_GetBuffer(args[6], &which, PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | PyBUF_WRITABLE) < 0)
        goto fail_best;
    n0 = best.shape[0];
    n1 = best.shape[1];
    n_off = offs.shape[0];
    if (which.itemsize != (Py_ssize_t)sizeof(int) || which.ndim != 2 || which.format == NULL ||
        (strcmp(which.format, "i") != 0 && strcmp(which.format, "l") != 0) || which.shape[0] != n0 ||
        which.shape[1] != n1) {
        PyErr_SetString(PyExc_ValueError, "which must be a C-contiguous int32 array of best's shape");
        goto fail_which;
    }
    if (half0 < 0 || half1 < 0 || hp.shape[0] != n0 + 2 * half0 || hp.shape[1] != n1 + 2 * half1 ||
        lift.shape[0] != n_off || n_off < 1 || n_off > 2147483647L) {
        PyErr_SetString(PyExc_ValueError, "grid_dilation: hp must be best's shape padded by half0 and half1 a side, "
                                          "lift one value an offset, at least one offset");
        goto fail_which;
    }
    for (k = 0; k < n_off; k++) {
        long long a = ((const long long *)offs.buf)[2 * k], b = ((const long long *)offs.buf)[2 * k + 1];
        if (a < -half0 || a > half0 || b < -half1 || b > half1) {
            PyErr_SetString(PyExc_ValueError, "grid_dilation: an offset past the padding");
            goto fail_which;
        }
    }
    Py_BEGIN_ALLOW_THREADS
    hx_grid_dilation((const double *)hp.buf, (long)hp.shape[1], (long)n0, (long)n1, half0, half1,
                     (const long long *)offs.buf, (const double *)lift.buf, (long)n_off, (double *)best.buf,
                     (int *)which.buf);
    Py_END_ALLOW_THREADS
    ok = 1;
fail_which:
    PyBuffer_Release(&which);
fail_best:
    PyBuffer_Release(&best);
fail_lift:
    PyBuffer_Release(&lift);
fail_offs:
    PyBuffer_Release(&offs);
fail_hp:
    PyBuffer_Release(&hp);
    if (!ok)
        return NULL;
    Py_RETURN_NONE;
}

PyDoc_STRVAR(run_general_doc,
"run_general(code, kind, nominal, kinematic, pc_on, pc_mode, n_steps, period, record_every, tail_start,\n"
"            sp_t, prm, coeffs, aux, Phi, Wd, Wo, Bs, Binv, fast, mass, modal, K, C, f0, sp_p, vend, rest_len,\n"
"            delay, delta, fres, fmax, fc, pc_bmax, p0, v0, rec, summary, tail)\n--\n\n"
"The simulator's general loop (hx_run_general) for N runs, the GIL released. sp_t (m,) is shared; every\n"
"other array has a leading N axis: prm (N, 6), coeffs (N, rows, cols), aux (N, k), Phi, Wd, Wo (N, 2, nz, nz),\n"
"Bs, Binv (N, 2, n, n), fast (N, 2 or 0, n, 7), mass, K, C (N, n, n), modal (N, 2 or 0, n, n), f0, vend, p0, v0\n"
"(N, n), sp_p (N, m, n), rest_len, delta, fres, fmax, fc, pc_bmax (N,), delay (N,) int64, rec (N, n_rec, 4n + 4),\n"
"summary (N, N_SUMMARY), tail (N, n, n_tail); then optionally base (a Base or None) and a vibration, the tuple\n"
"(v, mass, gain, tau, seed, budget, reserve) of Renderer.set_vibration or None, each run's from its seed.");

static PyObject *run_general(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    enum { NB = 29 };
    static const int ndims[NB] = {1, 2, 3, 2, 4, 4, 4, 4, 4, 4, 3, 4, 3, 3, 2, 3, 2, 1, 1, 1, 1, 1, 1, 1, 2, 2, 3, 2, 3};
    static const char *names[NB] = {"sp_t", "prm", "coeffs", "aux", "Phi", "Wd", "Wo", "Bs", "Binv", "fast", "mass",
                                    "modal", "K", "C", "f0", "sp_p", "vend", "rest_len", "delay", "delta", "fres",
                                    "fmax", "fc", "pc_bmax", "p0", "v0", "rec", "summary", "tail"};
    enum { SPT, PRM, COEFFS, AUX, PHI, WD, WO, BS, BINV, FAST, MASS, MODAL, KK, CC, F0, SPP, VEND, REST, DELAY, DELTA,
           FRES, FMAX, FC, PCB, P0, V0, REC, SUMMARY, TAIL };
    Py_buffer b[NB];
    int code, kind, nominal, kinematic, pc_on, pc_ref /* its mode */, got = 0, i, rc = HX_OK, dim;
    long n_steps, record_every, tail_start, nz, n_fast, n_modal, m_sp;
    double period;
    Py_ssize_t N, r;
    (void)self;
    const hx_base *base = NULL;
    Py_buffer vb;
    int have_vib = 0;
    double vmass = 0.0, vgain = 0.0, vtau = 0.0, vbudget = -1.0, vreserve = 0.0;
    unsigned long long vseed = 0;
    if (nargs < 10 + NB || nargs > 12 + NB) {
        PyErr_SetString(PyExc_TypeError, "run_general takes 39 arguments, and optionally a Base and a vibration");
        return NULL;
    }
    if (nargs >= 11 + NB && args[10 + NB] != Py_None) {
        if (!Py_IS_TYPE(args[10 + NB], &BaseType)) {
            PyErr_SetString(PyExc_TypeError, "base must be a Base or None");
            return NULL;
        }
        base = &((BaseObject *)args[10 + NB])->base;
    }
    code = (int)PyLong_AsLong(args[0]);
    kind = (int)PyLong_AsLong(args[1]);
    nominal = PyObject_IsTrue(args[2]);
    kinematic = PyObject_IsTrue(args[3]);
    pc_on = PyObject_IsTrue(args[4]);
    pc_ref = (int)PyLong_AsLong(args[5]);
    if (pc_ref < 0 || pc_ref >= HX_N_STAB) {
        if (!PyErr_Occurred())
            PyErr_SetString(PyExc_ValueError, "pc_mode must be one of the HX_STAB_* codes");
        return NULL;
    }
    n_steps = PyLong_AsLong(args[6]);
    period = PyFloat_AsDouble(args[7]);
    record_every = PyLong_AsLong(args[8]);
    tail_start = PyLong_AsLong(args[9]);
    if (PyErr_Occurred())
        return NULL;
    if (nargs == 12 + NB && args[11 + NB] != Py_None) {
        PyObject *t = args[11 + NB];
        if (!PyTuple_Check(t)) {
            PyErr_SetString(PyExc_TypeError, "vibration must be a tuple (v, mass, gain, tau, seed, budget, reserve)");
            return NULL;
        }
        if (vib_settings(&PyTuple_GET_ITEM(t, 0), PyTuple_GET_SIZE(t), &vb, &vmass, &vgain, &vtau, &vseed, &vbudget,
                         &vreserve) < 0)
            return NULL;
        have_vib = 1;
    }
    for (got = 0; got < NB; got++) {
        int ok;
        if (got == DELAY) {
            ok = PyObject_GetBuffer(args[10 + got], &b[got], PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) == 0;
            if (ok && (b[got].itemsize != 8 || b[got].ndim != 1 || !is_int64(b[got].format))) {
                PyBuffer_Release(&b[got]);
                PyErr_SetString(PyExc_ValueError, "delay must be a C-contiguous int64 array");
                ok = 0;
            }
        } else {
            ok = get_doubles(args[10 + got], &b[got], got >= REC, ndims[got], names[got]) == 0;
        }
        if (!ok)
            goto done;
    }
    N = b[PRM].shape[0];
    dim = (int)b[F0].shape[1];
    nz = (long)b[PHI].shape[2];
    n_fast = (long)b[FAST].shape[1];
    n_modal = (long)b[MODAL].shape[1];
    m_sp = (long)b[SPT].shape[0];
    for (i = 1; i < NB; i++) {
        if (b[i].shape[0] != N) {
            PyErr_Format(PyExc_ValueError, "%s must have %zd runs", names[i], N);
            goto done;
        }
    }
    if ((dim != 2 && dim != 3) || b[PRM].shape[1] != HX_N_PARAMS || nz < 5 * dim || nz > 7 * dim ||
        b[PHI].shape[1] != 2 || b[PHI].shape[3] != nz || b[WD].shape[1] != 2 || b[WD].shape[2] != nz ||
        b[WD].shape[3] != nz || b[WO].shape[1] != 2 || b[WO].shape[2] != nz || b[WO].shape[3] != nz ||
        b[BS].shape[1] != 2 || b[BS].shape[2] != dim || b[BS].shape[3] != dim || b[BINV].shape[1] != 2 ||
        b[BINV].shape[2] != dim || b[BINV].shape[3] != dim || (n_fast != 0 && n_fast != 2) ||
        b[FAST].shape[2] != dim || b[FAST].shape[3] != HX_N_FAST || b[MASS].shape[1] != dim ||
        b[MASS].shape[2] != dim || (n_modal != 0 && n_modal != 2) || b[MODAL].shape[2] != dim ||
        b[MODAL].shape[3] != dim || (n_modal == 2) != (nz == 7 * dim) || b[KK].shape[1] != dim ||
        b[KK].shape[2] != dim || b[CC].shape[1] != dim || b[CC].shape[2] != dim || m_sp < 1 ||
        b[SPP].shape[1] != m_sp || b[SPP].shape[2] != dim || b[VEND].shape[1] != dim || b[P0].shape[1] != dim ||
        b[V0].shape[1] != dim || b[REC].shape[2] != 4 * dim + 4 || b[SUMMARY].shape[1] != HX_N_SUMMARY ||
        b[TAIL].shape[1] != dim || n_steps < 0 || record_every < 1 || tail_start < 0 || !(period > 0.0)) {
        PyErr_SetString(PyExc_ValueError, "run_general: arrays of inconsistent shapes or invalid counts");
        goto done;
    }
    for (r = 0; r < N; r++) {
        long long d = ((const long long *)b[DELAY].buf)[r];
        if (d < 0 || d > 100000000) {
            PyErr_SetString(PyExc_ValueError, "run_general: a delay outside [0, 1e8] samples");
            goto done;
        }
    }
    Py_BEGIN_ALLOW_THREADS
    for (r = 0; r < N && rc == HX_OK; r++) {
        hx_model m;
        hx_general_run run;
        hx_vib_channel vib;
        long n_rec = (long)b[REC].shape[1];
        long d = (long)((const long long *)b[DELAY].buf)[r], dd = dim * dim, zz = nz * nz;
        batch_model(&m, code, kind, &b[PRM], &b[COEFFS], &b[AUX], r);
        m.base = base;
        run.dim = dim;
        run.nz = nz;
        run.nominal = nominal;
        run.kinematic = kinematic;
        run.pc_on = pc_on;
        run.pc_mode = pc_ref;
        run.Phi = (const double *)b[PHI].buf + r * 2 * zz;
        run.Wd = (const double *)b[WD].buf + r * 2 * zz;
        run.Wo = (const double *)b[WO].buf + r * 2 * zz;
        run.Bs = (const double *)b[BS].buf + r * 2 * dd;
        run.Binv = (const double *)b[BINV].buf + r * 2 * dd;
        run.fast = n_fast ? (const double *)b[FAST].buf + r * 2 * dim * HX_N_FAST : NULL;
        run.mass = (const double *)b[MASS].buf + r * dd;
        run.modal = n_modal ? (const double *)b[MODAL].buf + r * 2 * dd : NULL;
        run.K = (const double *)b[KK].buf + r * dd;
        run.C = (const double *)b[CC].buf + r * dd;
        run.f0 = (const double *)b[F0].buf + r * dim;
        run.sp_t = (const double *)b[SPT].buf;
        run.sp_p = (const double *)b[SPP].buf + r * m_sp * dim;
        run.n_setpoints = m_sp;
        run.vend = (const double *)b[VEND].buf + r * dim;
        run.rest_len = ((const double *)b[REST].buf)[r];
        run.n_steps = n_steps;
        run.period = period;
        run.delay = d;
        run.delta = ((const double *)b[DELTA].buf)[r];
        run.fres = ((const double *)b[FRES].buf)[r];
        run.fmax = ((const double *)b[FMAX].buf)[r];
        run.fc = ((const double *)b[FC].buf)[r];
        run.pc_bmax = ((const double *)b[PCB].buf)[r];
        run.p0 = (const double *)b[P0].buf + r * dim;
        run.v0 = (const double *)b[V0].buf + r * dim;
        run.record_every = record_every;
        run.n_rec = n_rec;
        run.rec = (double *)b[REC].buf + r * n_rec * (4 * dim + 4);
        run.summary = (double *)b[SUMMARY].buf + r * HX_N_SUMMARY;
        run.tail_start = tail_start;
        run.n_tail = (long)b[TAIL].shape[2];
        run.tail = (double *)b[TAIL].buf + r * dim * run.n_tail;
        run.vib = NULL;
        if (have_vib) {
            hx_vib_channel_set(&vib, (const double *)vb.buf, vmass, vgain, vtau, vseed, vbudget, vreserve);
            run.vib = &vib;
        }
        run.delay_buffer = malloc(sizeof(double) * (size_t)((d + 1) * dim));
        if (run.delay_buffer == NULL) {
            rc = HX_NO_MEMORY;
            break;
        }
        rc = hx_run_general(&m, &run);
        free(run.delay_buffer);
    }
    Py_END_ALLOW_THREADS
    if (rc == HX_NO_MEMORY)
        PyErr_NoMemory();
    else if (rc != HX_OK)
        core_error(rc);
done:
    for (i = 0; i < got; i++)
        PyBuffer_Release(&b[i]);
    if (have_vib)
        PyBuffer_Release(&vb);
    if (PyErr_Occurred())
        return NULL;
    Py_RETURN_NONE;
}

PyDoc_STRVAR(tail_amplitudes_doc,
"tail_amplitudes(u, a1, a2)\n--\n\n"
"hx_tail_amplitudes on each row of u (float64 (N, m), any strides: a view of the simulator's tail), detrended\n"
"in place; the half amplitudes of each row's halves into a1, a2 (float64 (N,)).");

static PyObject *tail_amplitudes(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer u, a1, a2;
    Py_ssize_t r, n, m, rs, cs;
    (void)self;
    if (nargs != 3) {
        PyErr_SetString(PyExc_TypeError, "tail_amplitudes takes 3 arguments");
        return NULL;
    }
    if (PyObject_GetBuffer(args[0], &u, PyBUF_STRIDES | PyBUF_FORMAT | PyBUF_WRITABLE) < 0)
        return NULL;
    if (u.itemsize != 8 || u.format == NULL || strcmp(u.format, "d") != 0 || u.ndim != 2 ||
        u.strides[0] % 8 != 0 || u.strides[1] % 8 != 0 || u.strides[0] < 0 || u.strides[1] < 0) {
        PyBuffer_Release(&u);
        PyErr_SetString(PyExc_ValueError, "u must be a 2-D float64 array with non-negative strides");
        return NULL;
    }
    if (get_doubles(args[1], &a1, 1, 1, "a1") < 0) {
        PyBuffer_Release(&u);
        return NULL;
    }
    if (get_doubles(args[2], &a2, 1, 1, "a2") < 0) {
        PyBuffer_Release(&a1);
        PyBuffer_Release(&u);
        return NULL;
    }
    n = u.shape[0];
    m = u.shape[1];
    rs = u.strides[0] / 8;
    cs = u.strides[1] / 8;
    if (a1.shape[0] != n || a2.shape[0] != n) {
        PyErr_SetString(PyExc_ValueError, "a1 and a2 must have one value per row of u");
    } else {
        Py_BEGIN_ALLOW_THREADS
        for (r = 0; r < n; r++)
            hx_tail_amplitudes((double *)u.buf + r * rs, (long)m, (long)cs, (double *)a1.buf + r, (double *)a2.buf + r);
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&a2);
    PyBuffer_Release(&a1);
    PyBuffer_Release(&u);
    if (PyErr_Occurred())
        return NULL;
    Py_RETURN_NONE;
}

PyDoc_STRVAR(free_run_doc,
"free_run(c, fc, force, p0, v0, pos)\n--\n\n"
"hx_free_run, the GIL released: a free rigid handle under held forces, in windows. c float64 (n, N_FAST) the\n"
"axes' zero-order-hold coefficients, or (W, S, n, N_FAST) each step's own (ticks of their own lengths); fc the\n"
"isotropic Coulomb friction (N); force (W, S, n) (N); p0, v0 (W, n) (m, m/s), each window's start, overwritten\n"
"with its end state; pos (W, S, n) written (m), n in 1..3.");

static PyObject *free_run(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer c, f, p0, v0, pos;
    double fc;
    long n, w, s;
    int ok = 0;
    (void)self;
    if (nargs != 6) {
        PyErr_SetString(PyExc_TypeError, "free_run takes 6 arguments");
        return NULL;
    }
    fc = PyFloat_AsDouble(args[1]);
    if (fc == -1.0 && PyErr_Occurred())
        return NULL;
    if (get_doubles(args[0], &c, 0, -1, "c") < 0)
        return NULL;
    if (c.ndim != 2 && c.ndim != 4) {
        PyErr_SetString(PyExc_ValueError, "free_run: c must be (n, N_FAST) or (W, S, n, N_FAST)");
        PyBuffer_Release(&c);
        return NULL;
    }
    if (get_doubles(args[2], &f, 0, 3, "force") < 0)
        goto c_done;
    if (get_doubles(args[3], &p0, 1, 2, "p0") < 0)
        goto f_done;
    if (get_doubles(args[4], &v0, 1, 2, "v0") < 0)
        goto p0_done;
    if (get_doubles(args[5], &pos, 1, 3, "pos") < 0)
        goto v0_done;
    n = (long)c.shape[c.ndim - 2];
    w = (long)f.shape[0];
    s = (long)f.shape[1];
    if (n < 1 || n > 3 || c.shape[c.ndim - 1] != HX_N_FAST || f.shape[2] != n || p0.shape[0] != w ||
        p0.shape[1] != n || v0.shape[0] != w || v0.shape[1] != n || pos.shape[0] != w || pos.shape[1] != s ||
        pos.shape[2] != n || !(fc >= 0.0) || (c.ndim == 4 && (c.shape[0] != w || c.shape[1] != s))) {
        PyErr_SetString(PyExc_ValueError, "free_run: shapes c (n, N_FAST) or (W, S, n, N_FAST), force and pos "
                                          "(W, S, n), p0 and v0 (W, n), n in 1..3, fc >= 0");
    } else {
        long c_step = c.ndim == 4 ? n * HX_N_FAST : 0;
        Py_BEGIN_ALLOW_THREADS
        hx_free_run(n, (const double *)c.buf, c_step, fc, w, s, (const double *)f.buf, (double *)p0.buf,
                    (double *)v0.buf, (double *)pos.buf);
        Py_END_ALLOW_THREADS
        ok = 1;
    }
    PyBuffer_Release(&pos);
v0_done:
    PyBuffer_Release(&v0);
p0_done:
    PyBuffer_Release(&p0);
f_done:
    PyBuffer_Release(&f);
c_done:
    PyBuffer_Release(&c);
    if (!ok)
        return NULL;
    Py_RETURN_NONE;
}

PyDoc_STRVAR(presliding_plane_doc,
"presliding_plane(dx, dy, ddx, ddy, d_max, z_stick, table)\n--\n\n"
"One step of isotropic presliding in the plane (hx_presliding_plane): the deflection (dx, dy) (m) after the\n"
"in-plane displacement (ddx, ddy) (m); z_stick < 0 for the sharp model, else the smooth one with its travel\n"
"table (haptex.friction.smooth_table). Returns (dx, dy, table steps).");

static PyObject *presliding_plane(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    double v[6], d[2], dp[2];
    Py_buffer tab;
    long work = 0;
    int i;
    (void)self;
    if (nargs != 7) {
        PyErr_SetString(PyExc_TypeError, "presliding_plane takes 7 arguments");
        return NULL;
    }
    for (i = 0; i < 6; i++) {
        v[i] = PyFloat_AsDouble(args[i]);
        if (v[i] == -1.0 && PyErr_Occurred())
            return NULL;
    }
    if (!(v[4] > 0.0) || !isfinite(v[4])) {
        PyErr_SetString(PyExc_ValueError, "d_max must be > 0");
        return NULL;
    }
    if (get_doubles(args[6], &tab, 0, 1, "table") < 0)
        return NULL;
    if (v[5] >= 0.0 && (v[5] >= v[4] || hx_presliding_table_check((const double *)tab.buf, (long)tab.shape[0]) != HX_OK)) {
        PyBuffer_Release(&tab);
        PyErr_SetString(PyExc_ValueError, "a smooth step needs 0 <= z_stick < d_max and its travel table");
        return NULL;
    }
    d[0] = v[0];
    d[1] = v[1];
    dp[0] = v[2];
    dp[1] = v[3];
    hx_presliding_plane(d, dp, v[4], v[5], (const double *)tab.buf, &work);
    PyBuffer_Release(&tab);
    return Py_BuildValue("(ddl)", d[0], d[1], work);
}

static int lsf_valid(const double *w, int n);

PyDoc_STRVAR(haply_wakeup_doc, "haply_wakeup(port, timeout)\n--\n\nWake the Inverse3 on the serial port haply_open opened "
                               "(hx_haply.c): 0x0A sent, and the 21 bytes after its 0x0B answer returned (id uint16, "
                               "model, hardware, firmware uint8, a 16-byte UUID); OSError naming the failure when no "
                               "answer comes within timeout s (0-10) or it is not the wakeup's. The GIL is released.");

static PyObject *haply_wakeup(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    hx_haply h;
    unsigned char info[21];
    Py_ssize_t fd;
    double timeout;
    int rc;
    (void)self;
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "haply_wakeup takes port, timeout");
        return NULL;
    }
    fd = PyLong_AsSsize_t(args[0]);
    timeout = PyFloat_AsDouble(args[1]);
    if (PyErr_Occurred())
        return NULL;
    if (fd < 0 || !(timeout > 0.0 && timeout <= 10.0)) {
        PyErr_SetString(PyExc_ValueError, "haply_wakeup: a port (haply_open's) >= 0 and a timeout in (0, 10] s");
        return NULL;
    }
    memset(&h, 0, sizeof h);
    h.fd = (intptr_t)fd;
    Py_BEGIN_ALLOW_THREADS
    rc = hx_haply_wakeup(&h, timeout, info);
    Py_END_ALLOW_THREADS
    if (rc != 0)
        return PyErr_Format(PyExc_OSError, "haply: the wakeup failed (%s)", haply_error(rc));
    return PyBytes_FromStringAndSize((const char *)info, sizeof info);
}

PyDoc_STRVAR(haply_open_doc, "haply_open(name)\n--\n\nOpen the Inverse3's serial port for haply_wakeup and the servo "
                             "thread (hx_haply.c's hx_haply_open): on POSIX a terminal by its path, raw, buffers "
                             "flushed; on Windows a COM port by name ('COM3'), raw 8N1, no flow control. Returns the "
                             "port (an int: a file descriptor, or a HANDLE); OSError (the system's reason) if it "
                             "cannot be opened or is not a serial port. haply_close(port) closes it.");

static PyObject *haply_open(PyObject *self, PyObject *arg)
{
    const char *name;
    intptr_t port = -1;
    int rc;
    (void)self;
    name = PyUnicode_AsUTF8(arg);
    if (name == NULL)
        return NULL;
    Py_BEGIN_ALLOW_THREADS
    rc = hx_haply_open(name, &port);
    Py_END_ALLOW_THREADS
    if (rc != 0) {
#ifdef _WIN32
        return PyErr_SetFromWindowsErr(0);
#else
        return PyErr_SetFromErrno(PyExc_OSError);
#endif
    }
    return PyLong_FromSsize_t((Py_ssize_t)port);
}

PyDoc_STRVAR(haply_close_doc, "haply_close(port)\n--\n\nClose a port haply_open opened.");

static PyObject *haply_close(PyObject *self, PyObject *arg)
{
    Py_ssize_t port = PyLong_AsSsize_t(arg);
    (void)self;
    if (port == -1 && PyErr_Occurred())
        return NULL;
    if (port < 0) {
        PyErr_SetString(PyExc_ValueError, "haply_close: a port haply_open returned");
        return NULL;
    }
    hx_haply_close((intptr_t)port);
    Py_RETURN_NONE;
}

PyDoc_STRVAR(vibration_doc, "vibration(v, speed, force, out, seed)\n--\n\nThe data-driven vibration (m/s^2) of "
                            "model set v (hx_vibration.c's layout) at each sample's speed (m/s) and force (N) into out "
                            "(float64 (N,) each), from a fresh state seeded with seed; the GIL released. Returns "
                            "(clamped, faults, largest work of a sample).");

static PyObject *vibration(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer v, sp, fo, out;
    hx_vib_state st;
    unsigned long long seed;
    long maxw = 0;
    Py_ssize_t i, n;
    int rc;
    (void)self;
    if (nargs != 5) {
        PyErr_SetString(PyExc_TypeError, "vibration takes v, speed, force, out, seed");
        return NULL;
    }
    seed = PyLong_AsUnsignedLongLongMask(args[4]);
    if (PyErr_Occurred())
        return NULL;
    if (get_doubles(args[0], &v, 0, 1, "v") < 0)
        return NULL;
    if (get_doubles(args[1], &sp, 0, 1, "speed") < 0) {
        PyBuffer_Release(&v);
        return NULL;
    }
    if (get_doubles(args[2], &fo, 0, 1, "force") < 0) {
        PyBuffer_Release(&v);
        PyBuffer_Release(&sp);
        return NULL;
    }
    if (get_doubles(args[3], &out, 1, 1, "out") < 0) {
        PyBuffer_Release(&v);
        PyBuffer_Release(&sp);
        PyBuffer_Release(&fo);
        return NULL;
    }
    n = out.shape[0];
    rc = hx_vib_check((const double *)v.buf, (long)v.shape[0]);
    if (rc == HX_OK && (sp.shape[0] != n || fo.shape[0] != n)) {
        PyErr_SetString(PyExc_ValueError, "speed, force and out must have the same length");
        rc = -1;
    } else if (rc != HX_OK) {
        core_error(rc);
    }
    if (rc == HX_OK) {
        const double *vv = (const double *)v.buf, *s = (const double *)sp.buf, *f = (const double *)fo.buf;
        double *o = (double *)out.buf;
        Py_BEGIN_ALLOW_THREADS
        hx_vib_reset(&st, seed);
        for (i = 0; i < n; i++) {
            o[i] = hx_vib_step(vv, &st, s[i], f[i]);
            if (st.work > maxw)
                maxw = st.work;
        }
        Py_END_ALLOW_THREADS
    }
    PyBuffer_Release(&v);
    PyBuffer_Release(&sp);
    PyBuffer_Release(&fo);
    PyBuffer_Release(&out);
    if (rc != HX_OK)
        return NULL;
    return Py_BuildValue("(lll)", st.clamped, st.faults, maxw);
}

PyDoc_STRVAR(normal_doc, "normal(seed, out)\n--\n\nThe core's N(0, 1) samples 0, 1, ... of seed into out (float64 "
                         "(N,)): what the vibration's noise is before its standard deviation.");

static PyObject *normal(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer out;
    unsigned long long seed;
    Py_ssize_t i;
    (void)self;
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "normal takes seed, out");
        return NULL;
    }
    seed = PyLong_AsUnsignedLongLongMask(args[0]);
    if (PyErr_Occurred())
        return NULL;
    if (get_doubles(args[1], &out, 1, 1, "out") < 0)
        return NULL;
    for (i = 0; i < out.shape[0]; i++)
        ((double *)out.buf)[i] = hx_normal(seed, (unsigned long long)i);
    PyBuffer_Release(&out);
    Py_RETURN_NONE;
}

PyDoc_STRVAR(lsf_to_poly_doc, "lsf_to_poly(w, a)\n--\n\nThe polynomial [1, a_1, ..., a_p] (a, float64 (p + 1,)) "
                              "of the ascending line spectral frequencies w (rad, float64 (p,), checked).");

static PyObject *lsf_to_poly(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    Py_buffer w, a;
    Py_ssize_t p;
    (void)self;
    if (nargs != 2) {
        PyErr_SetString(PyExc_TypeError, "lsf_to_poly takes w, a");
        return NULL;
    }
    if (get_doubles(args[0], &w, 0, 1, "w") < 0)
        return NULL;
    if (get_doubles(args[1], &a, 1, 1, "a") < 0) {
        PyBuffer_Release(&w);
        return NULL;
    }
    p = w.shape[0];
    if (a.shape[0] != p + 1 || p > HX_VIB_MAX_ORDER || !lsf_valid((const double *)w.buf, (int)p)) {
        PyBuffer_Release(&w);
        PyBuffer_Release(&a);
        PyErr_SetString(PyExc_ValueError, "w must ascend in (0, pi), at most HX_VIB_MAX_ORDER of them, a be p + 1 long");
        return NULL;
    }
    hx_lsf_to_poly((const double *)w.buf, (int)p, (double *)a.buf);
    PyBuffer_Release(&w);
    PyBuffer_Release(&a);
    Py_RETURN_NONE;
}

static int lsf_valid(const double *w, int n)
{
    int k;
    for (k = 0; k < n; k++)
        if (!(w[k] > 0.0 && w[k] < 3.14159265358979323846) || (k > 0 && !(w[k] > w[k - 1])))
            return 0;
    return 1;
}

static PyMethodDef methods[] = {
    {"field", (PyCFunction)(void (*)(void))field, METH_FASTCALL, field_doc},
    {"vibration", (PyCFunction)(void (*)(void))vibration, METH_FASTCALL, vibration_doc},
    {"haply_wakeup", (PyCFunction)(void (*)(void))haply_wakeup, METH_FASTCALL, haply_wakeup_doc},
    {"haply_open", (PyCFunction)haply_open, METH_O, haply_open_doc},
    {"haply_close", (PyCFunction)haply_close, METH_O, haply_close_doc},
    {"normal", (PyCFunction)(void (*)(void))normal, METH_FASTCALL, normal_doc},
    {"lsf_to_poly", (PyCFunction)(void (*)(void))lsf_to_poly, METH_FASTCALL, lsf_to_poly_doc},
    {"texture", (PyCFunction)(void (*)(void))texture, METH_FASTCALL, texture_doc},
    {"contact_ascent", (PyCFunction)(void (*)(void))contact_ascent, METH_FASTCALL, contact_ascent_doc},
    {"grid_dilation", (PyCFunction)(void (*)(void))grid_dilation, METH_FASTCALL, grid_dilation_doc},
    {"checked", (PyCFunction)(void (*)(void))checked, METH_FASTCALL, checked_doc},
    {"checks", (PyCFunction)checks, METH_NOARGS, checks_doc},
    {"run_lean", (PyCFunction)(void (*)(void))run_lean, METH_FASTCALL, run_lean_doc},
    {"run_general", (PyCFunction)(void (*)(void))run_general, METH_FASTCALL, run_general_doc},
    {"tail_amplitudes", (PyCFunction)(void (*)(void))tail_amplitudes, METH_FASTCALL, tail_amplitudes_doc},
    {"free_run", (PyCFunction)(void (*)(void))free_run, METH_FASTCALL, free_run_doc},
    {"presliding_plane", (PyCFunction)(void (*)(void))presliding_plane, METH_FASTCALL, presliding_plane_doc},
    {"closest_profile", (PyCFunction)(void (*)(void))closest_profile, METH_FASTCALL, closest_profile_doc},
    {"closest_surface", (PyCFunction)(void (*)(void))closest_surface, METH_FASTCALL, closest_surface_doc},
    {"leaf_bounds", (PyCFunction)(void (*)(void))leaf_bounds, METH_FASTCALL, leaf_bounds_doc},
    {"table_cells", (PyCFunction)(void (*)(void))table_cells, METH_FASTCALL, table_cells_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_ext", "haptex's C core (see haptex.core).", -1, methods,
    NULL, NULL, NULL, NULL,
};

PyMODINIT_FUNC PyInit__ext(void)
{
    PyObject *mod;
    import_array(); /* NumPy's C API (returns NULL with NumPy's error when it cannot be imported) */
    mod = PyModule_Create(&module);
    struct { const char *name; int value; } consts[] = {
        {"TEXTURE_FLAT", HX_TEXTURE_FLAT}, {"TEXTURE_FOURIER", HX_TEXTURE_FOURIER},
        {"TEXTURE_SPLINE", HX_TEXTURE_SPLINE}, {"SURFACE_GRATINGS", HX_SURFACE_GRATINGS},
        {"SURFACE_PATCHES", HX_SURFACE_PATCHES},
        {"ALG_W", HX_ALG_W}, {"ALG_A", HX_ALG_A}, {"ALG_B", HX_ALG_B}, {"ALG_C", HX_ALG_C},
        {"ALG_D", HX_ALG_D}, {"ALG_E", HX_ALG_E}, {"ALG_F", HX_ALG_F}, {"ALG_G", HX_ALG_G},
        {"ALG_PROXY", HX_ALG_PROXY}, {"PROXY_STEPS", HX_PROXY_STEPS}, {"PROXY_HALVINGS", HX_PROXY_HALVINGS},
        {"N_PARAMS", HX_N_PARAMS}, {"P_K0", HX_P_K0}, {"P_DZMAX", HX_P_DZMAX}, {"P_MU", HX_P_MU},
        {"P_DXMAX", HX_P_DXMAX}, {"P_SCALE", HX_P_SCALE}, {"P_ZSTICK", HX_P_ZSTICK},
        {"CP_VERTICAL", HX_CP_VERTICAL}, {"CP_PERIODIC", HX_CP_PERIODIC}, {"CP_FINITE", HX_CP_FINITE},
        {"CP_OPEN", HX_CP_OPEN}, {"A_MODE", HX_A_MODE}, {"A_START", HX_A_START}, {"A_PERIOD", HX_A_PERIOD},
        {"A_TREELEN", HX_A_TREELEN}, {"A_NLEAF", HX_A_NLEAF}, {"A_STEP", HX_A_STEP}, {"A_SLOPE", HX_A_SLOPE},
        {"A_CURV", HX_A_CURV}, {"A_HMIN", HX_A_HMIN}, {"A_TMIN", HX_A_TMIN}, {"A_WCAP", HX_A_WCAP},
        {"A_X0", HX_A_X0}, {"A_XE", HX_A_XE}, {"A_HL", HX_A_HL}, {"A_SL", HX_A_SL}, {"A_HR", HX_A_HR},
        {"A_SR", HX_A_SR}, {"A_TIE", HX_A_TIE}, {"A_JERK", HX_A_JERK}, {"A_TABLE", HX_A_TABLE},
        {"A_LEAFC", HX_A_LEAFC}, {"A_TREE", HX_A_TREE}, {"G_HMIN", HX_G_HMIN}, {"G_SLOPE", HX_G_SLOPE},
        {"G_CURV", HX_G_CURV},
        {"G_LEAF", HX_G_LEAF}, {"G_TIE", HX_G_TIE}, {"G_HMAX", HX_G_HMAX}, {"G_CONVEX", HX_G_CONVEX},
        {"G_JERK", HX_G_JERK}, {"G_SLOPE_BOUND", HX_G_SLOPE_BOUND}, {"G_CURV_BOUND", HX_G_CURV_BOUND},
        {"N_GAUX", HX_N_GAUX}, {"G_EDGE", HX_G_EDGE}, {"G_PYRAMID", HX_G_PYRAMID}, {"PY_NX", HX_PY_NX},
        {"PY_NY", HX_PY_NY}, {"PY_SHIFT", HX_PY_SHIFT}, {"PY_LEVELS", HX_PY_LEVELS}, {"PY_HEAD", HX_PY_HEAD},
        {"PY_N", HX_PY_N}, {"G_BUDGET", HX_G_BUDGET}, {"N_E", HX_N_E}, {"S_EX", HX_S_EX}, {"S_EZ", HX_S_EZ}, {"S_DAMP", HX_S_DAMP}, {"S_OP", HX_S_OP},
        {"S_KE0", HX_S_KE0}, {"S_KE", HX_S_KE}, {"S_SAT", HX_S_SAT}, {"S_MAXPEN", HX_S_MAXPEN},
        {"S_NSAMP", HX_S_NSAMP}, {"S_TAILSTART_E", HX_S_TAILSTART_E}, {"S_DIVERGED", HX_S_DIVERGED},
        {"S_DIVERGED_WHAT", HX_S_DIVERGED_WHAT}, {"S_FRIC", HX_S_FRIC}, {"S_STUCK", HX_S_STUCK}, {"S_EY", HX_S_EY},
        {"S_PC_ACTIVE", HX_S_PC_ACTIVE}, {"S_PC_ENERGY", HX_S_PC_ENERGY}, {"S_VIB_SUPPLIED", HX_S_VIB_SUPPLIED}, {"S_VIB_CUT", HX_S_VIB_CUT}, {"S_VIB_CLAMPED", HX_S_VIB_CLAMPED}, {"N_SUMMARY", HX_N_SUMMARY}, {"DIVERGED_POSITION", HX_DIVERGED_POSITION},
        {"DIVERGED_VELOCITY", HX_DIVERGED_VELOCITY}, {"DIVERGED_FORCE", HX_DIVERGED_FORCE},
        {"DIVERGED_ENERGY", HX_DIVERGED_ENERGY}, {"F_PV", HX_F_PV}, {"F_PW", HX_F_PW}, {"F_VV", HX_F_VV},
        {"F_VW", HX_F_VW}, {"F_CVV", HX_F_CVV}, {"F_CVW", HX_F_CVW}, {"F_CWW", HX_F_CWW}, {"N_FAST", HX_N_FAST}, {"T_N", HX_T_N}, {"T_LOGR", HX_T_LOGR}, {"T_DV", HX_T_DV},
        {"T_BETA", HX_T_BETA}, {"T_DATA", HX_T_DATA}, {"TB_X0", HX_TB_X0}, {"TB_PERIOD", HX_TB_PERIOD},
        {"TB_W", HX_TB_W}, {"TB_NX", HX_TB_NX}, {"TB_Z0", HX_TB_Z0}, {"TB_NZ", HX_TB_NZ}, {"TB_CELLS", HX_TB_CELLS},
        {"PIECE", HX_PIECE}, {"TABLE_MAXP", HX_TABLE_MAXP}, {"PATCH_X0", HX_PATCH_X0}, {"PATCH_Y0", HX_PATCH_Y0},
        {"PATCH_DX", HX_PATCH_DX}, {"PATCH_DY", HX_PATCH_DY}, {"PATCH_NX", HX_PATCH_NX}, {"PATCH_NY", HX_PATCH_NY},
        {"PATCH_PERIODIC", HX_PATCH_PERIODIC},
        {"PATCH_JOINS", HX_PATCH_JOINS}, {"PATCH_AXES", HX_PATCH_AXES}, {"PATCH_TURN", HX_PATCH_TURN},
        {"PATCH_DATA", HX_PATCH_DATA},
        {"JOINS_SPLINE", HX_JOINS_SPLINE}, {"JOINS_HERMITE", HX_JOINS_HERMITE}, {"JOINS_BRANCHED", HX_JOINS_BRANCHED},
        {"MAX_BRANCHES", HX_MAX_BRANCHES},
        {"CONVEX_EVALS", HX_CONVEX_EVALS},
        {"PC_RING", HX_PC_RING}, {"STAB_PC", HX_STAB_PC}, {"STAB_PC_STORED", HX_STAB_PC_STORED},
        {"STAB_EBA", HX_STAB_EBA}, {"STAB_PSPM", HX_STAB_PSPM}, {"BASE_PLANE", HX_BASE_PLANE}, {"BASE_CYLINDER", HX_BASE_CYLINDER},
        {"BASE_SPHERE", HX_BASE_SPHERE}, {"BASE_MESH", HX_BASE_MESH}, {"FACE", HX_FACE}, {"FACE_N", HX_FACE_N},
        {"FACE_M", HX_FACE_M}, {"FACE_UV", HX_FACE_UV}, {"FACE_EDGE", HX_FACE_EDGE}, {"FACE_VERTEX", HX_FACE_VERTEX},
        {"FACE_VN", HX_FACE_VN}, {"FACE_NEXT", HX_FACE_NEXT},
    };
    size_t i;
    if (mod == NULL)
        return NULL;
    if (PyType_Ready(&RendererType) < 0 || PyModule_AddObjectRef(mod, "Renderer", (PyObject *)&RendererType) < 0 ||
        PyType_Ready(&ServoType) < 0 || PyModule_AddObjectRef(mod, "Servo", (PyObject *)&ServoType) < 0 ||
        PyType_Ready(&BaseType) < 0 || PyModule_AddObjectRef(mod, "Base", (PyObject *)&BaseType) < 0 ||
        PyType_Ready(&PlantType) < 0 || PyModule_AddObjectRef(mod, "Plant", (PyObject *)&PlantType) < 0 ||
        PyType_Ready(&CheckedType) < 0) {
        Py_DECREF(mod);
        return NULL;
    }
    for (i = 0; i < sizeof consts / sizeof consts[0]; i++) {
        if (PyModule_AddIntConstant(mod, consts[i].name, consts[i].value) < 0) {
            Py_DECREF(mod);
            return NULL;
        }
    }
    {
        PyObject *v = PyFloat_FromDouble(HX_CONVEX_MIN);
        int rc = v == NULL ? -1 : PyModule_AddObjectRef(mod, "CONVEX_MIN", v);
        Py_XDECREF(v);
        if (rc < 0) {
            Py_DECREF(mod);
            return NULL;
        }
    }
    return mod;
}

/* One GPME accelerations call of a compiled gpmegen model from Python at close to the cost of
   the C itself (see fastcall.py, which builds, tests and loads this file).

   The same for every model: it knows a model library only by the address of its
   <prefix>_gpme_accelerations, given with the model's parameter values and partition when a
   Caller is made. A call (t, q, qd) whose t is a float (or an int, or a numpy.float64) and whose
   q and qd are numpy float64 arrays of shape (n,), C-contiguous, aligned and in native byte order
   goes straight to that function; every other call (lists, other dtypes or shapes, a batch,
   keywords) goes to the Caller's fallback, the checked Python path, so it gives exactly what
   that path gives; so does a state that is not finite, which that path refuses (finite.py). A
   failed solve raises the exception the Caller's `failure(status, t)` returns.

   The GIL is released during the C only when the Caller is made with release_gil (cmodel.py
   decides by the model's size): releasing and taking it back costs about 0.05 us a call, 5% of
   the C at n_rfe = 5, where other threads would gain little; at larger models the C is long
   enough for them to run meanwhile. */

#define PY_SSIZE_T_CLEAN
#define NPY_NO_DEPRECATED_API NPY_1_7_API_VERSION
#include <Python.h>
#include <numpy/arrayobject.h>
#include <numpy/arrayscalars.h>
#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

typedef int (*accelerations_fn)(double t, const double *q, const double *qd, const double *p,
                                const int *dependent, const int *independent, double *qdd);

typedef struct {
    PyObject_HEAD
    vectorcallfunc vectorcall;
    accelerations_fn function;
    npy_intp n;
    double *p;            /* private copies, made once: the model's own values */
    int *dependent;
    int *independent;
    PyObject *fallback;   /* (t, q, qd) -> qdd: every call not of the fast form */
    PyObject *failure;    /* (status, t) -> the exception of a failed solve */
    PyObject *library;    /* held so that the function's library stays loaded */
    int release_gil;      /* whether other threads run while the C does */
} Caller;

/* t as a double when it is a float, a numpy.float64 or an int (as float(t) gives it), else 0. */
static int as_time(PyObject *t, double *value)
{
    if (PyFloat_CheckExact(t)) {
        *value = PyFloat_AS_DOUBLE(t);
        return 1;
    }
    if (PyArray_IsScalar(t, Double)) {
        *value = PyArrayScalar_VAL(t, Double);
        return 1;
    }
    if (PyLong_CheckExact(t)) {
        *value = PyLong_AsDouble(t);
        if (*value == -1.0 && PyErr_Occurred()) {
            PyErr_Clear(); /* too large: the checked path says so */
            return 0;
        }
        return 1;
    }
    return 0;
}

/* Whether x is a plain float64 array of shape (n,) that C can read as it is. */
static int is_state(PyObject *x, npy_intp n)
{
    if (!PyArray_CheckExact(x)) {
        return 0;
    }
    PyArrayObject *a = (PyArrayObject *)x;
    return PyArray_NDIM(a) == 1 && PyArray_DIM(a, 0) == n && PyArray_TYPE(a) == NPY_DOUBLE
           && PyArray_ISNOTSWAPPED(a) && PyArray_CHKFLAGS(a, NPY_ARRAY_C_CONTIGUOUS | NPY_ARRAY_ALIGNED);
}

/* Whether t and the n entries of q and qd are all finite (2n comparisons: nothing beside the C). */
static int is_finite_state(double t, const double *q, const double *qd, npy_intp n)
{
    if (!isfinite(t)) {
        return 0;
    }
    for (npy_intp i = 0; i < n; ++i) {
        if (!isfinite(q[i]) || !isfinite(qd[i])) {
            return 0;
        }
    }
    return 1;
}

static PyObject *failed(Caller *self, int status, PyObject *t)
{
    PyObject *exc = PyObject_CallFunction(self->failure, "iO", status, t);
    if (exc == NULL) {
        return NULL;
    }
    if (PyExceptionInstance_Check(exc)) {
        PyErr_SetObject((PyObject *)Py_TYPE(exc), exc);
    } else {
        PyErr_SetString(PyExc_SystemError, "the failure callable of a fast-call Caller returned no exception");
    }
    Py_DECREF(exc);
    return NULL;
}

static PyObject *caller_call(PyObject *obj, PyObject *const *args, size_t nargsf, PyObject *kwnames)
{
    Caller *self = (Caller *)obj;
    double t;
    if (PyVectorcall_NARGS(nargsf) != 3 || kwnames != NULL || !as_time(args[0], &t)
        || !is_state(args[1], self->n) || !is_state(args[2], self->n)) {
        return PyObject_Vectorcall(self->fallback, args, nargsf, kwnames);
    }
    const double *q = PyArray_DATA((PyArrayObject *)args[1]), *qd = PyArray_DATA((PyArrayObject *)args[2]);
    if (!is_finite_state(t, q, qd, self->n)) {
        return PyObject_Vectorcall(self->fallback, args, nargsf, kwnames);
    }
    PyObject *qdd = PyArray_SimpleNew(1, &self->n, NPY_DOUBLE);
    if (qdd == NULL) {
        return NULL;
    }
    double *out = PyArray_DATA((PyArrayObject *)qdd);
    int status;
    if (self->release_gil) {
        /* q and qd stay alive: the caller holds them; p and the partition are the Caller's own */
        Py_BEGIN_ALLOW_THREADS
        status = self->function(t, q, qd, self->p, self->dependent, self->independent, out);
        Py_END_ALLOW_THREADS
    } else {
        status = self->function(t, q, qd, self->p, self->dependent, self->independent, out);
    }
    if (status != 0) {
        Py_DECREF(qdd);
        return failed(self, status, args[0]);
    }
    return qdd;
}

/* A private copy of the values of the one-axis `array` of `type` (NPY_DOUBLE or NPY_INT), one
   element at least (C has no empty arrays); NULL with an exception set when it is not such an array. */
static void *copy_of(PyObject *array, int type, size_t size, const char *what)
{
    if (!PyArray_CheckExact(array) || PyArray_TYPE((PyArrayObject *)array) != type
        || !PyArray_ISCARRAY_RO((PyArrayObject *)array) || !PyArray_ISNOTSWAPPED((PyArrayObject *)array)
        || PyArray_NDIM((PyArrayObject *)array) != 1) {
        PyErr_Format(PyExc_TypeError, "%s must be a contiguous one-axis array of %s", what,
                     type == NPY_DOUBLE ? "float64" : "intc");
        return NULL;
    }
    npy_intp count = PyArray_SIZE((PyArrayObject *)array);
    void *copy = PyMem_Calloc(count > 0 ? (size_t)count : 1, size);
    if (copy == NULL) {
        PyErr_NoMemory();
        return NULL;
    }
    memcpy(copy, PyArray_DATA((PyArrayObject *)array), (size_t)count * size);
    return copy;
}

static PyObject *caller_new(PyTypeObject *type, PyObject *args, PyObject *kwargs)
{
    unsigned long long address;
    Py_ssize_t n;
    PyObject *p, *dependent, *independent, *fallback, *failure, *library;
    int release_gil = 0;
    static char *names[] = {"address", "n", "p", "dependent", "independent", "fallback", "failure", "library",
                            "release_gil", NULL};
    if (!PyArg_ParseTupleAndKeywords(args, kwargs, "KnOOOOOO|p:Caller", names, &address, &n, &p, &dependent,
                                     &independent, &fallback, &failure, &library, &release_gil)) {
        return NULL;
    }
    if (address == 0 || n <= 0 || !PyCallable_Check(fallback) || !PyCallable_Check(failure)) {
        PyErr_SetString(PyExc_ValueError, "Caller needs a function address, n > 0 and two callables");
        return NULL;
    }
    /* The function reads one dependent index per constraint and one independent index per other
       coordinate: together n of them. */
    if (PyArray_Check(dependent) && PyArray_Check(independent)
        && PyArray_SIZE((PyArrayObject *)dependent) + PyArray_SIZE((PyArrayObject *)independent) < n) {
        PyErr_SetString(PyExc_ValueError, "the dependent and independent indices must number n together");
        return NULL;
    }
    Caller *self = PyObject_GC_New(Caller, type);
    if (self == NULL) {
        return NULL;
    }
    self->vectorcall = caller_call;
    self->function = (accelerations_fn)(uintptr_t)address;
    self->n = (npy_intp)n;
    self->release_gil = release_gil;
    self->p = copy_of(p, NPY_DOUBLE, sizeof(double), "p");
    self->dependent = self->p ? copy_of(dependent, NPY_INT, sizeof(int), "dependent") : NULL;
    self->independent = self->dependent ? copy_of(independent, NPY_INT, sizeof(int), "independent") : NULL;
    Py_INCREF(fallback);
    Py_INCREF(failure);
    Py_INCREF(library);
    self->fallback = fallback;
    self->failure = failure;
    self->library = library;
    PyObject_GC_Track(self);
    if (self->independent == NULL) {
        Py_DECREF(self);
        return NULL;
    }
    return (PyObject *)self;
}

static int caller_traverse(Caller *self, visitproc visit, void *arg)
{
    Py_VISIT(self->fallback);
    Py_VISIT(self->failure);
    Py_VISIT(self->library);
    return 0;
}

static int caller_clear(Caller *self)
{
    Py_CLEAR(self->fallback);
    Py_CLEAR(self->failure);
    Py_CLEAR(self->library);
    return 0;
}

static void caller_dealloc(Caller *self)
{
    PyObject_GC_UnTrack(self);
    caller_clear(self);
    PyMem_Free(self->p);
    PyMem_Free(self->dependent);
    PyMem_Free(self->independent);
    PyObject_GC_Del(self);
}

static PyTypeObject CallerType = {
    PyVarObject_HEAD_INIT(NULL, 0)
    .tp_name = "gpmegen_fastcall.Caller",
    .tp_doc = "Caller(address, n, p, dependent, independent, fallback, failure, library, release_gil=False): "
              "(t, q, qd) -> qdd of one model's gpme_accelerations (see fastcall.py).",
    .tp_basicsize = sizeof(Caller),
    .tp_flags = Py_TPFLAGS_DEFAULT | Py_TPFLAGS_HAVE_GC | Py_TPFLAGS_HAVE_VECTORCALL,
    .tp_new = caller_new,
    .tp_dealloc = (destructor)caller_dealloc,
    .tp_traverse = (traverseproc)caller_traverse,
    .tp_clear = (inquiry)caller_clear,
    .tp_vectorcall_offset = offsetof(Caller, vectorcall),
    .tp_call = PyVectorcall_Call,
};

/* A function of gpme_accelerations' signature for the extension's own test run (fastcall.py):
   qdd_i = t + q_i + 2 qd_i + p_0 + 10 dependent_0 + 100 independent_0; status 2 when q_0 is negative. */
static int reference(double t, const double *q, const double *qd, const double *p, const int *dependent,
                     const int *independent, double *qdd)
{
    if (q[0] < 0.0) {
        return 2;
    }
    for (int i = 0; i < 3; ++i) {
        qdd[i] = t + q[i] + 2.0 * qd[i] + p[0] + 10.0 * dependent[0] + 100.0 * independent[0];
    }
    return 0;
}

static PyObject *reference_address(PyObject *module, PyObject *unused)
{
    (void)module;
    (void)unused;
    return PyLong_FromUnsignedLongLong((unsigned long long)(uintptr_t)reference);
}

static PyMethodDef functions[] = {
    {"reference_address", reference_address, METH_NOARGS,
     "The address of a test function of gpme_accelerations' signature for n = 3 (see fastcall.py)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT,
    .m_name = "gpmegen_fastcall",
    .m_doc = "Fast single-state calls of compiled gpmegen models.",
    .m_size = -1,
    .m_methods = functions,
};

PyMODINIT_FUNC PyInit_gpmegen_fastcall(void)
{
    import_array();
    if (PyType_Ready(&CallerType) < 0) {
        return NULL;
    }
    PyObject *m = PyModule_Create(&module);
    if (m == NULL) {
        return NULL;
    }
    Py_INCREF(&CallerType);
    if (PyModule_AddObject(m, "Caller", (PyObject *)&CallerType) < 0) {
        Py_DECREF(&CallerType);
        Py_DECREF(m);
        return NULL;
    }
    return m;
}

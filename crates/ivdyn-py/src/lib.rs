//! `ivdyn._ivdyn`: the native module behind the `ivdyn` Python package.
//!
//! Thin by design: convert NumPy arrays to row-major slices, call `ivdyn` (the batch
//! functions of `ivdyn::batch`, with the GIL released) writing straight into a NumPy-allocated
//! output array. Shapes here are always batched, `(T, N)`; the Python
//! wrapper (`python/ivdyn/__init__.py`) accepts `(N,)` too, converts dtypes and layouts,
//! and is the public API.

// `!(x > 0.0)` is deliberate throughout: it is true for NaN, which must be rejected too.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod control;
mod error;
mod fleet;
mod ident;
mod pipeline;
mod terminal;

use std::borrow::Cow;

use error::to_py;
use ivdyn::batch;
use numpy::ndarray::{Ix2, Ix3};
use numpy::{
    IntoPyArray, PyArray, PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

/// A serial robot arm (native part). Use `ivdyn.Robot`, which wraps it.
#[pyclass(name = "Robot", module = "ivdyn._ivdyn")]
#[derive(Clone)]
struct PyRobot {
    inner: ivdyn::Robot,
    /// The URDF it was loaded from (the start of a URDF write-back).
    urdf: Option<std::path::PathBuf>,
}

/// Contiguous row-major data of a `(T, n)` array: borrowed when C-contiguous, else copied.
/// `t` is the expected row count (from the first argument) or `None`.
fn rows<'a>(x: &'a PyReadonlyArray2<'_, f64>, name: &str, n: usize, t: Option<usize>) -> PyResult<Cow<'a, [f64]>> {
    let shape = x.shape();
    let ok = shape[1] == n && t.is_none_or(|t| shape[0] == t);
    if !ok {
        let want = match t {
            Some(t) => format!("({t}, {n})"),
            None => format!("(T, {n})"),
        };
        return Err(PyValueError::new_err(format!("{name} must have shape {want}, got ({}, {})", shape[0], shape[1])));
    }
    // `as_slice` also accepts Fortran order (column-major data): only borrow C order
    Ok(match x.as_slice() {
        Ok(s) if x.is_c_contiguous() => Cow::Borrowed(s),
        _ => Cow::Owned(x.as_array().iter().copied().collect()),
    })
}

/// The output array: the caller's `out` (checked: float64, C-contiguous, writeable, shape
/// `dims`), or a new C-order array allocated by NumPy (whose allocator asks for transparent
/// huge pages on large arrays: a 288 MB regressor batch then costs a few hundred page
/// faults instead of 70 000). `fill` writes every element of its data with the GIL
/// released; the worker threads of `ivdyn::batch` write (and so first touch) disjoint
/// chunks, so the kernel's page zeroing is spread over the threads too.
fn output<'py, D, E>(
    py: Python<'py>,
    dims: D,
    out: Option<Bound<'py, PyAny>>,
    fill: impl FnOnce(&mut [f64]) -> Result<(), E> + Send,
) -> PyResult<Bound<'py, PyArray<f64, D>>>
where
    D: numpy::ndarray::Dimension,
    E: Send,
    PyErr: From<E>,
{
    let arr = match out {
        Some(o) => out_array(o, &dims)?,
        None => PyArray::<f64, D>::zeros(py, dims, false),
    };
    {
        let mut rw = arr.try_readwrite().map_err(|e| PyValueError::new_err(format!("out: {e}")))?;
        let out =
            rw.as_slice_mut().map_err(|e| PyRuntimeError::new_err(format!("internal error: output array: {e}")))?;
        py.detach(|| fill(out))?;
    }
    Ok(arr)
}

/// `out` as a float64 C-contiguous writeable array of shape `dims`, or `ValueError`.
fn out_array<'py, D: numpy::ndarray::Dimension>(
    o: Bound<'py, PyAny>,
    dims: &D,
) -> PyResult<Bound<'py, PyArray<f64, D>>> {
    let shape_str = |s: &[usize]| format!("({})", s.iter().map(|v| v.to_string()).collect::<Vec<_>>().join(", "));
    let want = shape_str(dims.slice());
    let arr = o
        .cast_into::<PyArray<f64, D>>()
        .map_err(|e| PyValueError::new_err(format!("out must be a float64 numpy array of shape {want} ({e})")))?;
    if arr.shape() != dims.slice() {
        return Err(PyValueError::new_err(format!("out must have shape {want}, got {}", shape_str(arr.shape()))));
    }
    if !arr.is_c_contiguous() {
        return Err(PyValueError::new_err("out must be C-contiguous (it is written in place)"));
    }
    Ok(arr)
}

/// Carries an `ivdyn::Error` out of a GIL-free closure (orphan rule: no `From` for PyErr).
struct Batch(ivdyn::Error);

impl From<Batch> for PyErr {
    fn from(e: Batch) -> PyErr {
        to_py(e.0)
    }
}

#[pymethods]
impl PyRobot {
    /// Loads a serial chain from a URDF file (fixed joints fused, side branches locked;
    /// the bodies below a given tip dropped unless `fuse_beyond_tip`).
    #[staticmethod]
    #[pyo3(signature = (path, base=None, tip=None, fuse_beyond_tip=false))]
    fn from_urdf(
        path: std::path::PathBuf,
        base: Option<&str>,
        tip: Option<&str>,
        fuse_beyond_tip: bool,
    ) -> PyResult<Self> {
        let opts =
            ivdyn::robot::urdf::UrdfOptions { fuse_beyond_tip, ..ivdyn::robot::urdf::UrdfOptions::new(base, tip) };
        Ok(PyRobot { inner: ivdyn::Robot::from_urdf_with(&path, &opts).map_err(to_py)?, urdf: Some(path) })
    }

    /// The paper's six-joint robot (Tables 1 and 2).
    #[staticmethod]
    fn paper() -> Self {
        PyRobot { inner: ivdyn::Robot::paper(), urdf: None }
    }

    /// Revolute chain from a standard DH table (m, rad), all parameters zero.
    #[staticmethod]
    #[pyo3(signature = (a, d, alpha, offset=None))]
    fn from_dh(a: Vec<f64>, d: Vec<f64>, alpha: Vec<f64>, offset: Option<Vec<f64>>) -> PyResult<Self> {
        let inner = batch::robot_from_dh(&a, &d, &alpha, offset.as_deref()).map_err(to_py)?;
        Ok(PyRobot { inner, urdf: None })
    }

    /// An independent copy.
    fn copy(&self) -> Self {
        self.clone()
    }

    #[getter]
    fn name(&self) -> String {
        self.inner.name.clone()
    }

    #[getter]
    fn dof(&self) -> usize {
        self.inner.dof()
    }

    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.inner.joint_names.clone()
    }

    #[getter]
    fn link_names(&self) -> Vec<String> {
        self.inner.link_names.clone()
    }

    #[getter]
    fn base_link(&self) -> String {
        self.inner.base_link.clone()
    }

    #[getter]
    fn tip_link(&self) -> String {
        self.inner.tip_link.clone()
    }

    #[getter]
    fn locked_joints(&self) -> Vec<String> {
        self.inner.locked_joints.clone()
    }

    #[getter]
    fn fused_links(&self) -> Vec<(String, String)> {
        self.inner.fused_links.clone()
    }

    #[getter]
    fn dropped_links(&self) -> Vec<String> {
        self.inner.dropped_links.clone()
    }

    /// What loading left out of the chain and where it went, and links whose inertials no
    /// body has, one line each (`Robot::chain_notes`: the command line's `note:` lines).
    #[getter]
    fn notes(&self) -> Vec<String> {
        self.inner.chain_notes()
    }

    #[getter]
    fn param_names(&self) -> Vec<String> {
        self.inner.param_names()
    }

    /// Parameter vector `theta`, shape `(14 N,)` (a copy).
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.params().into_pyarray(py)
    }

    #[setter]
    fn set_params(&mut self, theta: PyReadonlyArray1<'_, f64>) -> PyResult<()> {
        let theta = theta.as_array().iter().copied().collect::<Vec<f64>>();
        self.inner.set_params(&theta).map_err(to_py)
    }

    /// Inverse dynamics with drive terms; `(T, N)` each -> `(T, N)`.
    #[pyo3(signature = (q, qd, qdd, out=None))]
    fn rnea<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        qd: PyReadonlyArray2<'py, f64>,
        qdd: PyReadonlyArray2<'py, f64>,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = self.inner.dof();
        let q = rows(&q, "q", n, None)?;
        let t = q.len() / n;
        let (qd, qdd) = (rows(&qd, "qd", n, Some(t))?, rows(&qdd, "qdd", n, Some(t))?);
        let robot = &self.inner;
        output(py, Ix2(t, n), out, |o| batch::rnea_batch(robot, &q, &qd, &qdd, o).map_err(Batch))
    }

    /// Gravity torques; `(T, N)` -> `(T, N)`.
    #[pyo3(signature = (q, out=None))]
    fn gravity<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = self.inner.dof();
        let q = rows(&q, "q", n, None)?;
        let t = q.len() / n;
        let robot = &self.inner;
        output(py, Ix2(t, n), out, |o| batch::gravity_batch(robot, &q, o).map_err(Batch))
    }

    /// Regressor; `(T, N)` each -> `(T, N, 14 N)` (or `(T, N, 10 N)` when `rigid_only`).
    #[pyo3(signature = (q, qd, qdd, rigid_only=false, out=None))]
    fn regressor<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        qd: PyReadonlyArray2<'py, f64>,
        qdd: PyReadonlyArray2<'py, f64>,
        rigid_only: bool,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let n = self.inner.dof();
        let q = rows(&q, "q", n, None)?;
        let t = q.len() / n;
        let (qd, qdd) = (rows(&qd, "qd", n, Some(t))?, rows(&qdd, "qdd", n, Some(t))?);
        let p = if rigid_only { 10 * n } else { 14 * n };
        let robot = &self.inner;
        output(py, Ix3(t, n, p), out, |o| batch::regressor_batch(robot, &q, &qd, &qdd, o, rigid_only).map_err(Batch))
    }

    /// Mass matrices; `(T, N)` -> `(T, N, N)`.
    #[pyo3(signature = (q, out=None))]
    fn mass_matrix<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let n = self.inner.dof();
        let q = rows(&q, "q", n, None)?;
        let t = q.len() / n;
        let robot = &self.inner;
        output(py, Ix3(t, n, n), out, |o| batch::mass_matrix_batch(robot, &q, o).map_err(Batch))
    }

    /// Forward dynamics; `(T, N)` each -> `(T, N)`.
    #[pyo3(signature = (q, qd, tau, out=None))]
    fn forward_dynamics<'py>(
        &self,
        py: Python<'py>,
        q: PyReadonlyArray2<'py, f64>,
        qd: PyReadonlyArray2<'py, f64>,
        tau: PyReadonlyArray2<'py, f64>,
        out: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let n = self.inner.dof();
        let q = rows(&q, "q", n, None)?;
        let t = q.len() / n;
        let (qd, tau) = (rows(&qd, "qd", n, Some(t))?, rows(&tau, "tau", n, Some(t))?);
        let robot = &self.inner;
        output(py, Ix2(t, n), out, |o| batch::forward_dynamics_batch(robot, &q, &qd, &tau, o).map_err(Batch))
    }

    fn __repr__(&self) -> String {
        format!(
            "Robot(name={:?}, dof={}, base_link={:?}, tip_link={:?})",
            self.inner.name,
            self.inner.dof(),
            self.inner.base_link,
            self.inner.tip_link
        )
    }
}

/// Number of threads the batch functions use for `t` samples.
#[pyfunction]
fn batch_threads(t: usize) -> usize {
    batch::threads_for(t)
}

/// An inertia 6-vector `[Ixx, Ixy, Iyy, Ixz, Iyz, Izz]` (ivdyn) in URDF attribute order
/// `[Ixx, Ixy, Ixz, Iyy, Iyz, Izz]` (the Python package applies it to index arrays).
#[pyfunction]
fn inertia_to_urdf(i: [f64; 6]) -> [f64; 6] {
    ivdyn::core::inertia_to_urdf(i)
}

/// The inverse of [`inertia_to_urdf`].
#[pyfunction]
fn inertia_from_urdf(u: [f64; 6]) -> [f64; 6] {
    ivdyn::core::inertia_from_urdf(u)
}

#[pymodule]
fn _ivdyn(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyRobot>()?;
    ident::register(m)?;
    terminal::register(m)?;
    control::register(m)?;
    pipeline::register(m)?;
    fleet::register(m)?;
    m.add_function(wrap_pyfunction!(batch_threads, m)?)?;
    m.add_function(wrap_pyfunction!(inertia_to_urdf, m)?)?;
    m.add_function(wrap_pyfunction!(inertia_from_urdf, m)?)?;
    m.add("INERTIA_ORDER", ivdyn::core::INERTIA_ORDER.to_vec())?;
    m.add("INERTIA_URDF_ORDER", ivdyn::core::INERTIA_URDF_ORDER.to_vec())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("MAX_DOF", ivdyn::MAX_DOF)?;
    Ok(())
}

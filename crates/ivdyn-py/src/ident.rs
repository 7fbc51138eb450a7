//! Identification bindings: batch fits, base parameters, payload, recursive estimators,
//! log reading and the paper reproduction. Glue only: the work is in `ivdyn::ident`,
//! `ivdyn::ident::arrays`, `ivdyn::log` and `ivdyn_lab::repro`, called with the GIL released.
//! Inputs are C-contiguous float64 arrays (the Python wrapper converts); shapes are
//! checked here and reported as `ValueError`.

use std::borrow::Cow;

use crate::PyRobot;
use crate::error::to_py;
use ivdyn::ident::arrays::{self, RecursiveIv, RecursiveLs};
use ivdyn::ident::{BaseParams, FitReport};
use ivdyn_lab::repro::{self, Estimator, PaperSim};
use nalgebra::DMatrix;
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// Contiguous data of a 1-D array (borrowed when contiguous), length checked against `n`.
fn vec1<'a>(x: &'a PyReadonlyArray1<'_, f64>, name: &str, n: Option<usize>) -> PyResult<Cow<'a, [f64]>> {
    let len = x.shape()[0];
    if let Some(n) = n
        && len != n
    {
        return Err(PyValueError::new_err(format!("{name} must have shape ({n},), got ({len},)")));
    }
    Ok(match x.as_slice() {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => Cow::Owned(x.as_array().iter().copied().collect()),
    })
}

/// Contiguous row-major data of a 2-D array `(m, p)`; checks `p` and `m` when given.
fn mat<'a>(
    x: &'a PyReadonlyArray2<'_, f64>,
    name: &str,
    m: Option<usize>,
    p: Option<usize>,
) -> PyResult<Cow<'a, [f64]>> {
    let s = x.shape();
    if m.is_some_and(|m| m != s[0]) || p.is_some_and(|p| p != s[1]) {
        let d = |v: Option<usize>, c: &str| v.map_or(c.to_string(), |v| v.to_string());
        return Err(PyValueError::new_err(format!(
            "{name} must have shape ({}, {}), got ({}, {})",
            d(m, "M"),
            d(p, "P"),
            s[0],
            s[1]
        )));
    }
    Ok(match x.as_slice() {
        Ok(v) if x.is_c_contiguous() => Cow::Borrowed(v),
        _ => Cow::Owned(x.as_array().iter().copied().collect()),
    })
}

fn names_or_default(names: Option<Vec<String>>, p: usize) -> PyResult<Vec<String>> {
    match names {
        None => Ok(arrays::default_names(p)),
        Some(n) if n.len() == p => Ok(n),
        Some(n) => Err(PyValueError::new_err(format!("names must have {p} entries (one per column), got {}", n.len()))),
    }
}

fn matrix<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]).into_pyarray(py)
}

// ------------------------------------------------------------------ batch fits

/// Result of a batch fit (`ivdyn::ident::FitReport`).
#[pyclass(name = "FitReport", module = "ivdyn._ivdyn", frozen)]
pub struct PyFitReport {
    pub(crate) inner: FitReport,
}

#[pymethods]
impl PyFitReport {
    #[getter]
    fn method(&self) -> String {
        self.inner.method.clone()
    }
    #[getter]
    fn names(&self) -> Vec<String> {
        self.inner.names.clone()
    }
    #[getter]
    fn theta<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.theta.clone().into_pyarray(py)
    }
    #[getter]
    fn std<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.std.clone().into_pyarray(py)
    }
    #[getter]
    fn rel_std_pct<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.rel_std_pct.clone().into_pyarray(py)
    }
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.inner.covariance)
    }
    #[getter]
    fn sigma2(&self) -> f64 {
        self.inner.sigma2
    }
    #[getter]
    fn rows(&self) -> usize {
        self.inner.rows
    }
    #[getter]
    fn rank(&self) -> usize {
        self.inner.rank
    }
    #[getter]
    fn condition_number(&self) -> f64 {
        self.inner.condition_number
    }
    #[getter]
    fn unexcited(&self) -> Vec<String> {
        self.inner.unexcited.clone()
    }
    #[getter]
    fn dwh<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(t) = &self.inner.dwh else { return Ok(None) };
        let d = PyDict::new(py);
        d.set_item("statistic", t.statistic)?;
        d.set_item("dof", t.dof)?;
        d.set_item("p_value", t.p_value)?;
        d.set_item("ls_biased", t.ls_biased)?;
        Ok(Some(d))
    }
    #[getter]
    fn theta_ls<'py>(&self, py: Python<'py>) -> Option<Bound<'py, PyArray1<f64>>> {
        self.inner.theta_ls.clone().map(|v| v.into_pyarray(py))
    }
    fn to_dict<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        d.set_item("method", self.method())?;
        d.set_item("names", self.names())?;
        d.set_item("theta", self.theta(py))?;
        d.set_item("std", self.std(py))?;
        d.set_item("rel_std_pct", self.rel_std_pct(py))?;
        d.set_item("covariance", self.covariance(py))?;
        d.set_item("sigma2", self.sigma2())?;
        d.set_item("rows", self.rows())?;
        d.set_item("rank", self.rank())?;
        d.set_item("condition_number", self.condition_number())?;
        d.set_item("unexcited", self.unexcited())?;
        d.set_item("dwh", self.dwh(py)?)?;
        d.set_item("theta_ls", self.theta_ls(py))?;
        Ok(d)
    }
    fn __repr__(&self) -> String {
        self.inner.to_string()
    }
    /// A table for notebooks, drawn by the Python package (`ivdyn._results`), where the
    /// HTML of every result lives.
    fn _repr_html_(slf: &Bound<'_, Self>) -> PyResult<String> {
        slf.py().import("ivdyn._results")?.getattr("fit_report_html")?.call1((slf,))?.extract()
    }
}

/// Weighted least squares; `phi` `(M, P)`, `y` `(M,)`, `w` `(M,)` or None.
#[pyfunction]
#[pyo3(signature = (phi, y, w=None, names=None))]
fn fit_ls(
    py: Python<'_>,
    phi: PyReadonlyArray2<'_, f64>,
    y: PyReadonlyArray1<'_, f64>,
    w: Option<PyReadonlyArray1<'_, f64>>,
    names: Option<Vec<String>>,
) -> PyResult<PyFitReport> {
    let (m, p) = (phi.shape()[0], phi.shape()[1]);
    let names = names_or_default(names, p)?;
    let phi = mat(&phi, "Phi", None, None)?;
    let y = vec1(&y, "y", Some(m))?;
    let w = w.as_ref().map(|w| vec1(w, "w", Some(m))).transpose()?;
    let inner = py.detach(|| arrays::fit_ls_rows(&phi, &y, w.as_deref(), &names)).map_err(to_py)?;
    Ok(PyFitReport { inner })
}

/// Instrumental variables; `phi`, `z` `(M, P)`, `y` `(M,)`, `w` `(M,)` or None.
#[pyfunction]
#[pyo3(signature = (phi, z, y, w=None, names=None))]
fn fit_iv(
    py: Python<'_>,
    phi: PyReadonlyArray2<'_, f64>,
    z: PyReadonlyArray2<'_, f64>,
    y: PyReadonlyArray1<'_, f64>,
    w: Option<PyReadonlyArray1<'_, f64>>,
    names: Option<Vec<String>>,
) -> PyResult<PyFitReport> {
    let (m, p) = (phi.shape()[0], phi.shape()[1]);
    let names = names_or_default(names, p)?;
    let phi = mat(&phi, "Phi", None, None)?;
    let z = mat(&z, "Z", Some(m), Some(p))?;
    let y = vec1(&y, "y", Some(m))?;
    let w = w.as_ref().map(|w| vec1(w, "w", Some(m))).transpose()?;
    let inner = py.detach(|| arrays::fit_iv_rows(&phi, &z, &y, w.as_deref(), &names)).map_err(to_py)?;
    Ok(PyFitReport { inner })
}

// ------------------------------------------------------------------ base parameters

/// Base parameters (`ivdyn::ident::BaseParams`).
#[pyclass(name = "BaseParams", module = "ivdyn._ivdyn", frozen)]
pub struct PyBaseParams {
    pub(crate) inner: BaseParams,
}

#[pymethods]
impl PyBaseParams {
    #[getter]
    fn names(&self) -> Vec<String> {
        self.inner.names.clone()
    }
    #[getter]
    fn independent(&self) -> Vec<usize> {
        self.inner.independent.clone()
    }
    #[getter]
    fn dependent(&self) -> Vec<usize> {
        self.inner.dependent.clone()
    }
    #[getter]
    fn zero_columns(&self) -> Vec<usize> {
        self.inner.zero_columns.clone()
    }
    #[getter(K)]
    fn k<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        matrix(py, &self.inner.k)
    }
    #[getter]
    fn full_cols(&self) -> usize {
        self.inner.full_cols
    }
    #[getter]
    fn base_count(&self) -> usize {
        self.inner.base_count()
    }
    /// `(P,)` -> `(B,)`.
    fn project<'py>(
        &self,
        py: Python<'py>,
        theta_full: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let t = vec1(&theta_full, "theta_full", Some(self.inner.full_cols))?;
        Ok(self.inner.project(&t).map_err(to_py)?.into_pyarray(py))
    }
    /// `(B,)` -> `(P,)`.
    fn to_full<'py>(
        &self,
        py: Python<'py>,
        theta_base: PyReadonlyArray1<'py, f64>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let t = vec1(&theta_base, "theta_base", Some(self.inner.base_count()))?;
        Ok(self.inner.to_full(&t).map_err(to_py)?.into_pyarray(py))
    }
    /// `(M, P)` -> `(M, B)`.
    fn select<'py>(&self, py: Python<'py>, y_full: PyReadonlyArray2<'py, f64>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let (p, b) = (self.inner.full_cols, self.inner.base_count());
        let m = y_full.shape()[0];
        let y = mat(&y_full, "Y_full", None, Some(p))?;
        let base = &self.inner;
        let out = py.detach(|| base.select_rows(&y, m)).map_err(to_py)?;
        let arr = Array2::from_shape_vec((m, b), out).map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(arr.into_pyarray(py))
    }
    fn __repr__(&self) -> String {
        format!("BaseParams({} of {} parameters identifiable)", self.inner.base_count(), self.inner.full_cols)
    }
}

/// Base parameters of a robot from `samples` random states (over the 10 N inertial
/// columns only when `rigid_only`).
#[pyfunction]
#[pyo3(signature = (robot, samples=100, seed=1, rigid_only=false))]
fn base_params(
    py: Python<'_>,
    robot: PyRef<'_, PyRobot>,
    samples: usize,
    seed: u64,
    rigid_only: bool,
) -> PyResult<PyBaseParams> {
    let r = robot.inner.clone();
    let inner = crate::error::no_panic(|| {
        py.detach(|| ivdyn::ident::base::robot_base_params_with(&r, samples, seed, rigid_only)).map_err(to_py)
    })?;
    Ok(PyBaseParams { inner })
}

/// Fused, multi-threaded least-squares fit of `base` from samples: `q, qd, qdd, tau`
/// `(T, N)`, optional per-joint weights `(N,)`; the regressor is never materialised.
#[pyfunction]
#[pyo3(signature = (robot, base, q, qd, qdd, tau, joint_weight=None))]
#[allow(clippy::too_many_arguments)]
fn fit_robot(
    py: Python<'_>,
    robot: PyRef<'_, PyRobot>,
    base: PyRef<'_, PyBaseParams>,
    q: PyReadonlyArray2<'_, f64>,
    qd: PyReadonlyArray2<'_, f64>,
    qdd: PyReadonlyArray2<'_, f64>,
    tau: PyReadonlyArray2<'_, f64>,
    joint_weight: Option<PyReadonlyArray1<'_, f64>>,
) -> PyResult<PyFitReport> {
    let n = robot.inner.dof();
    let q = mat(&q, "q", None, Some(n))?;
    let t = q.len() / n.max(1);
    let (qd, qdd, tau) =
        (mat(&qd, "qd", Some(t), Some(n))?, mat(&qdd, "qdd", Some(t), Some(n))?, mat(&tau, "tau", Some(t), Some(n))?);
    let w = joint_weight.as_ref().map(|w| vec1(w, "joint_weight", Some(n))).transpose()?;
    let (r, b) = (&robot.inner, &base.inner);
    let inner = py.detach(|| ivdyn::ident::fit_ls_batch(r, b, &q, &qd, &qdd, &tau, w.as_deref())).map_err(to_py)?;
    Ok(PyFitReport { inner })
}

/// Payload (mass, com, inertia about the com: the physically possible payload nearest to the
/// fit) from a fit over `base`, with the fit's own payload in `physical`.
#[pyfunction]
fn payload_from_fit<'py>(
    py: Python<'py>,
    base: PyRef<'py, PyBaseParams>,
    fit: PyRef<'py, PyFitReport>,
    cols: Vec<usize>,
    full_names: Vec<String>,
) -> PyResult<Bound<'py, PyDict>> {
    let cols: [usize; 10] = cols.as_slice().try_into().map_err(|_| {
        PyValueError::new_err(format!("cols must have 10 entries (m, m*cx, .., Izz), got {}", cols.len()))
    })?;
    if let Some(&c) = cols.iter().find(|&&c| c >= base.inner.full_cols) {
        return Err(PyValueError::new_err(format!("cols: index {c} out of range (P = {})", base.inner.full_cols)));
    }
    if fit.inner.theta.len() != base.inner.base_count() {
        return Err(PyValueError::new_err(format!(
            "fit has {} parameters but base has {} base parameters",
            fit.inner.theta.len(),
            base.inner.base_count()
        )));
    }
    let est = ivdyn::ident::payload_from_fit(&base.inner, &fit.inner, &cols, &full_names)
        .map_err(to_py)?
        .map_err(|n| PyValueError::new_err(arrays::not_identifiable_message(&n)))?;
    let d = PyDict::new(py);
    d.set_item("mass", est.mass)?;
    d.set_item("com", est.com.to_vec().into_pyarray(py))?;
    d.set_item("inertia", est.inertia.to_vec().into_pyarray(py))?;
    d.set_item("mass_std", est.mass_std)?;
    d.set_item("com_std", est.com_std.to_vec().into_pyarray(py))?;
    d.set_item("inertia_std", est.inertia_std.to_vec().into_pyarray(py))?;
    d.set_item("params", est.params.to_vec().into_pyarray(py))?;
    // the physical section as the `payload` report's JSON has it (nested dicts and lists)
    let physical = serde_json::to_string(&est.physical)
        .map_err(|e| pyo3::exceptions::PyRuntimeError::new_err(format!("internal error: to JSON: {e}")))?;
    d.set_item("physical", py.import("json")?.call_method1("loads", (physical,))?)?;
    Ok(d)
}

// ------------------------------------------------------------------ recursive estimators

fn start_err(e: ivdyn::Error) -> PyErr {
    PyValueError::new_err(e.to_string())
}

/// Recursive least squares.
#[pyclass(name = "Rls", module = "ivdyn._ivdyn")]
pub struct PyRls {
    inner: RecursiveLs,
}

#[pymethods]
impl PyRls {
    #[new]
    #[pyo3(signature = (p, p0=1e4, forgetting=1.0, max_variance=None, outlier_gate=None))]
    fn new(p: usize, p0: f64, forgetting: f64, max_variance: Option<f64>, outlier_gate: Option<f64>) -> PyResult<Self> {
        crate::error::no_panic(|| {
            let mut inner = RecursiveLs::new(p, p0, forgetting).map_err(start_err)?;
            max_variance.map(|v| inner.set_max_variance(v)).transpose().map_err(start_err)?;
            outlier_gate.map(|g| inner.set_outlier_gate(g)).transpose().map_err(start_err)?;
            Ok(Self { inner })
        })
    }
    #[pyo3(signature = (phi, y, w=1.0))]
    fn update(&mut self, phi: PyReadonlyArray1<'_, f64>, y: f64, w: f64) -> PyResult<()> {
        let phi = vec1(&phi, "phi", Some(self.inner.p()))?;
        self.inner.update(&phi, y, w).map_err(to_py)
    }
    #[pyo3(signature = (phi, y, w=None))]
    fn update_many(
        &mut self,
        py: Python<'_>,
        phi: PyReadonlyArray2<'_, f64>,
        y: PyReadonlyArray1<'_, f64>,
        w: Option<PyReadonlyArray1<'_, f64>>,
    ) -> PyResult<()> {
        let m = phi.shape()[0];
        let phi = mat(&phi, "Phi", None, Some(self.inner.p()))?;
        let y = vec1(&y, "y", Some(m))?;
        let w = w.as_ref().map(|w| vec1(w, "w", Some(m))).transpose()?;
        let inner = &mut self.inner;
        py.detach(|| inner.update_many(&phi, &y, w.as_deref())).map_err(to_py)
    }
    #[getter]
    fn p(&self) -> usize {
        self.inner.p()
    }
    #[getter]
    fn theta<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.theta().to_vec().into_pyarray(py)
    }
    #[getter]
    fn covariance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = self.inner.p();
        let a = Array2::from_shape_vec((p, p), self.inner.covariance())
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(a.into_pyarray(py))
    }
    #[getter]
    fn count(&self) -> u64 {
        self.inner.count()
    }
    #[getter]
    fn forgetting(&self) -> f64 {
        self.inner.forgetting()
    }
    #[getter]
    fn max_variance(&self) -> f64 {
        self.inner.max_variance()
    }
    #[getter]
    fn outlier_gate(&self) -> f64 {
        self.inner.outlier_gate()
    }
    fn __repr__(&self) -> String {
        format!(
            "Rls(p={}, forgetting={}, max_variance={}, outlier_gate={}, count={})",
            self.inner.p(),
            self.inner.forgetting(),
            self.inner.max_variance(),
            self.inner.outlier_gate(),
            self.inner.count()
        )
    }
}

/// Recursive instrumental variables.
#[pyclass(name = "Riv", module = "ivdyn._ivdyn")]
pub struct PyRiv {
    inner: RecursiveIv,
}

#[pymethods]
impl PyRiv {
    #[new]
    #[pyo3(signature = (p, p0=1e4, forgetting=1.0, max_variance=None, outlier_gate=None))]
    fn new(p: usize, p0: f64, forgetting: f64, max_variance: Option<f64>, outlier_gate: Option<f64>) -> PyResult<Self> {
        crate::error::no_panic(|| {
            let mut inner = RecursiveIv::new(p, p0, forgetting).map_err(start_err)?;
            max_variance.map(|v| inner.set_max_variance(v)).transpose().map_err(start_err)?;
            outlier_gate.map(|g| inner.set_outlier_gate(g)).transpose().map_err(start_err)?;
            Ok(Self { inner })
        })
    }
    #[pyo3(signature = (phi, z, y, w=1.0))]
    fn update(&mut self, phi: PyReadonlyArray1<'_, f64>, z: PyReadonlyArray1<'_, f64>, y: f64, w: f64) -> PyResult<()> {
        let p = self.inner.p();
        let phi = vec1(&phi, "phi", Some(p))?;
        let z = vec1(&z, "z", Some(p))?;
        self.inner.update(&phi, &z, y, w).map_err(to_py)
    }
    #[pyo3(signature = (phi, z, y, w=None))]
    fn update_many(
        &mut self,
        py: Python<'_>,
        phi: PyReadonlyArray2<'_, f64>,
        z: PyReadonlyArray2<'_, f64>,
        y: PyReadonlyArray1<'_, f64>,
        w: Option<PyReadonlyArray1<'_, f64>>,
    ) -> PyResult<()> {
        let (m, p) = (phi.shape()[0], self.inner.p());
        let phi = mat(&phi, "Phi", None, Some(p))?;
        let z = mat(&z, "Z", Some(m), Some(p))?;
        let y = vec1(&y, "y", Some(m))?;
        let w = w.as_ref().map(|w| vec1(w, "w", Some(m))).transpose()?;
        let inner = &mut self.inner;
        py.detach(|| inner.update_many(&phi, &z, &y, w.as_deref())).map_err(to_py)
    }
    #[getter]
    fn p(&self) -> usize {
        self.inner.p()
    }
    #[getter]
    fn theta<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.theta().to_vec().into_pyarray(py)
    }
    #[getter(P)]
    fn p_matrix<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = self.inner.p();
        let a =
            Array2::from_shape_vec((p, p), self.inner.p_matrix()).map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(a.into_pyarray(py))
    }
    #[getter]
    fn count(&self) -> u64 {
        self.inner.count()
    }
    #[getter]
    fn forgetting(&self) -> f64 {
        self.inner.forgetting()
    }
    #[getter]
    fn max_variance(&self) -> f64 {
        self.inner.max_variance()
    }
    #[getter]
    fn outlier_gate(&self) -> f64 {
        self.inner.outlier_gate()
    }
    fn __repr__(&self) -> String {
        format!(
            "Riv(p={}, forgetting={}, max_variance={}, outlier_gate={}, count={})",
            self.inner.p(),
            self.inner.forgetting(),
            self.inner.max_variance(),
            self.inner.outlier_gate(),
            self.inner.count()
        )
    }
}

// ------------------------------------------------------------------ logs

/// Reads an MCAP or CSV joint log -> dict of arrays.
#[pyfunction]
#[pyo3(signature = (path, joint_names, topic="/joint_states", command_topic=None))]
fn read_joint_states<'py>(
    py: Python<'py>,
    path: std::path::PathBuf,
    joint_names: Vec<String>,
    topic: &str,
    command_topic: Option<&str>,
) -> PyResult<Bound<'py, PyDict>> {
    if joint_names.is_empty() {
        return Err(PyValueError::new_err("joint_names must not be empty"));
    }
    let log = py.detach(|| ivdyn::log::read_joint_log(&path, &joint_names, topic, command_topic)).map_err(to_py)?;
    crate::pipeline::log_dict(py, log)
}

// ------------------------------------------------------------------ paper reproduction

/// The paper's simulation set-up for one seed of nominal-model errors.
#[pyclass(name = "PaperSim", module = "ivdyn._ivdyn")]
pub struct PyPaperSim {
    inner: PaperSim,
    seed: u64,
}

fn check_counts(what: &str, c: &[usize]) -> PyResult<()> {
    if c.is_empty() || c[0] == 0 || c.windows(2).any(|w| w[1] <= w[0]) {
        return Err(PyValueError::new_err(format!(
            "{what} must be a non-empty, strictly increasing list of positive sample counts"
        )));
    }
    Ok(())
}

fn estimates3<'py>(py: Python<'py>, x: &[Vec<Vec<f64>>], b: usize) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let (v, e, c) = arrays::flatten3(x, b).map_err(to_py)?;
    let a = Array3::from_shape_vec((e, c, b), v).map_err(|e| PyValueError::new_err(e.to_string()))?;
    Ok(a.into_pyarray(py))
}

#[pymethods]
impl PyPaperSim {
    #[new]
    fn new(py: Python<'_>, seed: u64) -> PyResult<Self> {
        let inner = py.detach(|| PaperSim::new(seed)).map_err(to_py)?;
        Ok(Self { inner, seed })
    }
    #[getter]
    fn seed(&self) -> u64 {
        self.seed
    }
    #[getter]
    fn base_names(&self) -> Vec<String> {
        self.inner.base.names.clone()
    }
    #[getter]
    fn full_names(&self) -> Vec<String> {
        repro::terminal_names(&self.inner.spec, 6)
    }
    #[getter]
    fn truth_base<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.inner.truth_base.clone().into_pyarray(py)
    }
    #[getter]
    fn dt(&self) -> f64 {
        self.inner.dt
    }
    #[getter]
    fn accel_noise(&self) -> f64 {
        self.inner.accel_noise
    }
    #[setter]
    fn set_accel_noise(&mut self, v: f64) -> PyResult<()> {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(PyValueError::new_err(format!("accel_noise must be finite and >= 0, got {v}")));
        }
        self.inner.accel_noise = v;
        Ok(())
    }
    #[getter]
    fn row_weight(&self) -> Vec<f64> {
        self.inner.row_weight.to_vec()
    }
    /// `(estimators, checkpoints, B)`.
    fn batch_estimates<'py>(
        &self,
        py: Python<'py>,
        noise_seed: u64,
        checkpoints: Vec<usize>,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        check_counts("checkpoints", &checkpoints)?;
        let sim = &self.inner;
        let out = py.detach(|| repro::batch_estimates(sim, noise_seed, &checkpoints)).map_err(to_py)?;
        estimates3(py, &out, sim.base.base_count())
    }
    /// `(estimators, record, B)`.
    #[pyo3(signature = (noise_seed, record, p0=1e4))]
    fn recursive_traces<'py>(
        &self,
        py: Python<'py>,
        noise_seed: u64,
        record: Vec<usize>,
        p0: f64,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        check_counts("record", &record)?;
        if !(p0 > 0.0 && p0.is_finite()) {
            return Err(PyValueError::new_err(format!("p0 must be finite and > 0, got {p0}")));
        }
        let sim = &self.inner;
        let out = py.detach(|| repro::recursive_traces(sim, noise_seed, &record, p0)).map_err(to_py)?;
        estimates3(py, &out, sim.base.base_count())
    }
    fn __repr__(&self) -> String {
        format!(
            "PaperSim(seed={}, base parameters={}, accel_noise={})",
            self.seed,
            self.inner.base.base_count(),
            self.inner.accel_noise
        )
    }
}

/// Labels of the estimators, in the order of the first axis of the estimates.
#[pyfunction]
fn paper_estimators() -> Vec<&'static str> {
    Estimator::ALL.iter().map(|e| e.label()).collect()
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyFitReport>()?;
    m.add_class::<PyBaseParams>()?;
    m.add_class::<PyRls>()?;
    m.add_class::<PyRiv>()?;
    m.add_class::<PyPaperSim>()?;
    m.add_function(wrap_pyfunction!(fit_ls, m)?)?;
    m.add_function(wrap_pyfunction!(fit_iv, m)?)?;
    m.add_function(wrap_pyfunction!(base_params, m)?)?;
    m.add_function(wrap_pyfunction!(fit_robot, m)?)?;
    m.add_function(wrap_pyfunction!(payload_from_fit, m)?)?;
    m.add_function(wrap_pyfunction!(read_joint_states, m)?)?;
    m.add_function(wrap_pyfunction!(paper_estimators, m)?)?;
    Ok(())
}

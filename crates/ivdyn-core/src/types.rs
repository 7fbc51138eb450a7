//! The scalar, vector and matrix types every module shares, and the lane type the
//! kernels are generic over.

/// Scalar type used everywhere.
pub type Real = f64;

/// A real number, or a pack of real numbers computed in lock step (one sample per lane):
/// `f64` on a controller, simba's `AutoF64x4` in `ivdyn`'s batch kernels. The kinematic
/// passes and the regressor ([`crate::kinematics`], [`crate::regressor`]) are written once for any such
/// `T`, so the batch path runs the same arithmetic in the same order as the single-sample
/// path (results agree bit for bit; the joint angles' sines and cosines come from
/// [`crate::trig::sin_cos`] on both).
pub trait Lanes: nalgebra::SimdRealField<Element = f64> + Copy {}
impl<T: nalgebra::SimdRealField<Element = f64> + Copy> Lanes for T {}
/// 3-vector.
pub type Vec3 = nalgebra::Vector3<f64>;
/// 3x3 matrix.
pub type Mat3 = nalgebra::Matrix3<f64>;
/// Joint-space vector of a chain with `N` joints.
pub type VecN<const N: usize> = nalgebra::SVector<f64, N>;
/// Joint-space matrix of a chain with `N` joints.
pub type MatN<const N: usize> = nalgebra::SMatrix<f64, N, N>;

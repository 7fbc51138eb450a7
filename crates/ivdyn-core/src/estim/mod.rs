//! Recursive estimators (no allocation): least squares in UD-factorised form and the
//! instrumental-variable method (covariance and information forms), the paper's instrumental model (eq 35) and the
//! terminal-link problem (eqs 38-54).
//!
//! The estimators are generic over nalgebra dimensions: `Const<P>` on a controller (no
//! allocator needed), `Dyn` on the desktop when `alloc` is available, one implementation.

pub mod guard;
pub mod instrument;
pub mod riv;
pub mod riv_info;
pub mod rls;
pub mod terminal;
pub mod terminal_rows;

pub use guard::MAX_INFORMATION_RATIO;
pub use instrument::InstrumentModel;
pub use riv::Riv;
pub use riv_info::RivInfo;
pub use rls::Rls;
pub use terminal::{TerminalLink, TerminalSpec};

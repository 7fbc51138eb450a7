//! The one orchestration: [`identify`](identify::identify), [`payload`](payload::payload),
//! [`simulate`](simulate::simulate), and the streaming identify of log files
//! ([`stream`]). The command line and the Python package call these.

pub mod identify;
pub mod payload;
pub mod simulate;
pub mod stream;

pub use identify::{identify, identify_base, write_prediction, IdentifyOptions, IdentifyReport, Method};
pub use payload::{payload, Hidden, PayloadOptions, PayloadReport};
pub use simulate::{fourier_trajectory, simulate, true_robot, SimulateOptions, Trajectory};

//! Batch identification: streaming least squares and instrumental variables, base parameters, uncertainty.

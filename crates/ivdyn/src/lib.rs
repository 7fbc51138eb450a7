//! ivdyn (std)

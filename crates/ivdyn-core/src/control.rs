//! Controllers: computed torque and PD with gravity compensation.

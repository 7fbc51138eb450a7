//! Closed-loop simulation of the true model: fixed-step integration, torque limits, sensor noise and quantisation.

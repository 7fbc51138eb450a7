//! Closed-loop simulation and the computed-torque experiments (paper Fig. 5).

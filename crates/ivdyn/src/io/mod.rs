//! Log input and output: ROS 2 MCAP (JointState) and CSV.

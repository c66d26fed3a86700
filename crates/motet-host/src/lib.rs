//! The host side of motet: the virtual machine described by a machine file, job
//! checks, and the distribution of the trajectory to nodes.

pub mod distribute;
pub mod heater;
pub mod heater_loop;
pub mod heater_trace;
pub mod job;
pub mod loops;
pub mod machine;
mod machine_build;
mod machine_file;
mod machine_file_heaters;
mod machine_file_loops;
mod machine_kinematics;
pub mod module;
pub mod samples;
pub mod sensor_plan;
pub mod servo;
pub mod thermal;

pub use distribute::{Distributor, Subscription};
pub use job::{check_job, check_move, clamp_move, Clamps, JobCheck, MoveError};
pub use machine::{Actuator, Axis, Heater, Joint, Machine, MachineError, NodeSpec, Tool};
pub use servo::{MotorSpec, SensorKind, SensorSpec, ServoSpec};

//! motet-host's integration tests, one binary (each file a module): the
//! suite builds and links one test program for the crate instead of one a
//! file.

mod check_job;
mod distribution;
mod machine_errors;
mod machine_examples;
mod machine_fuzz;
mod machine_heater_loops;
mod machine_heaters;
mod machine_servo_errors;
mod module_props;
mod modules;
mod ramps_fit;

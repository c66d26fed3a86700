//! motet-svg's integration tests, one binary (each file a module): the
//! suite builds and links one test program for the crate instead of one a
//! file.

mod common;
mod hatch;
mod inputs;
mod pens;
mod shapes;

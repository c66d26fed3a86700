//! motet-gcode's integration tests, one binary (each file a module): the
//! suite builds and links one test program for the crate instead of one a
//! file.

mod arcs;
mod blocks;
mod codes;
mod common;
mod large_file;
mod props;
mod slicers;

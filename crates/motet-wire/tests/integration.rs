//! motet-wire's integration tests, one binary (each file a module): the
//! suite builds and links one test program for the crate instead of one a
//! file.

mod describe;
mod describe_sizes;
mod doc_sizes;
mod frame;
mod link;
mod stream;
mod sync;

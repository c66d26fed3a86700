//! Scripting a machine directly, as Gestalt's "import the machine" and the
//! MakerBot blog's `go(x, y, z)` do: no batch file in between.
//!
//! ```no_run
//! let mut m = motet_api::Machine::open("examples/plotter.toml")?;
//! m.move_to(&[("x", 20.0), ("y", 30.0)], None)?;   // travel
//! m.set_tool("pen", 1.0)?;                           // pen down
//! m.move_to(&[("x", 80.0)], Some(40.0))?;            // draw at 40 mm/s
//! m.set_tool("pen", 0.0)?;
//! m.wait()?;                                         // until the machine is at rest
//! println!("{:?}", m.position());
//! # Ok::<(), motet_api::ApiError>(())
//! ```
//!
//! Each call is checked (axis names, travel, kinematic reach) before anything
//! is queued, so a refused call leaves the queued motion untouched. Accepted
//! calls go straight into the planner's lookahead; planned segments stream to
//! the machine's nodes as soon as they are final. A call blocks only while a
//! node's segment queue is full; on the simulated machine that means the
//! simulated clock runs until a place frees up. `on_interrupt` lets a caller
//! stop such a call (Ctrl-C in the Python bindings) without losing or
//! repeating anything already accepted.

mod drawing;
pub mod job;
mod machine;
mod place;
pub mod placement;
pub mod reader;

pub use job::{job_name, load_job, plan_check, Job, JobError, JobKind, JobOptions};
pub use machine::{ApiError, Event, Machine};
pub use motet_planner::PlanError;
pub use motet_sim::{Held, Report};
pub use placement::{Placed, Placement, PlacementError};
pub use reader::{scan_job, JobReader, JobScan};

//! `acc-stock`: a 2.5D height-field (Z-map) stock, a flat (or ball-nose) end mill that
//! removes material along a tool path of straight moves, and the cutter–workpiece engagement at every path
//! step (entry and exit angle, radial width a_e, axial depth a_p, engaged span and arcs,
//! feed per tooth, removal rate). See `docs/stock.md` for the model, the conventions, the
//! file formats and the resolution.
//!
//! - [`ZMap`]: the stock (a box, a height-map file, or a [`StockFile`] `stock.toml`);
//! - [`Cutter`], [`Spindle`]: the tool (flat or ball nose) and its speed and sense of
//!   rotation;
//! - [`Move`]: one straight move of the tool tip (the NC interpreter's path segment);
//! - [`Sweep`]: machines the stock move by move and reports a [`StepEngagement`] per step.
//!
//! ```
//! use acc_stock::{Cutter, Move, Spindle, Sweep, SweepOptions, ZMap};
//! // A 100 × 40 × 10 mm block, top at z = 0, 0.25 mm cells; a Ø10 mm 4-flute end mill.
//! let stock = ZMap::from_box([0.0, 0.0, -10.0], [100.0, 40.0, 0.0], 0.25).unwrap();
//! let cutter = Cutter::flat(10.0, 4, 25.0).unwrap();
//! let mut sweep = Sweep::new(stock, cutter, Spindle::cw(1000.0), SweepOptions::default()).unwrap();
//! // A 3 mm deep slot straight through the block at 400 mm/min.
//! let steps = sweep.run(&[Move::feed([-10.0, 20.0, -3.0], [110.0, 20.0, -3.0], 400.0)]);
//! let mid = steps[steps.len() / 2];
//! assert!((mid.ae_mm - 10.0).abs() < 1e-9);                     // a_e = D
//! assert!((mid.span_rad - std::f64::consts::PI).abs() < 1e-9);  // 180° engaged
//! assert!((mid.ap_mm - 3.0).abs() < 1e-6);                      // a_p = 3 mm
//! assert!((mid.feed_per_tooth_mm - 0.1).abs() < 1e-12);         // 400 / (1000 · 4)
//! // The removed volume is the slot's: 10 × 3 × 100 mm³.
//! let removed: f64 = steps.iter().map(|s| s.removed_mm3).sum();
//! assert!((removed - 3000.0).abs() < 1.0);
//! ```

#![deny(missing_docs)]

pub mod cutter;
pub mod engagement;
pub mod error;
pub mod heightmap;
pub mod motion;
pub mod spec;
pub mod sweep;
pub mod zigzag;
pub mod zmap;

pub use cutter::{Cutter, Rotation, Shape, Spindle};
pub use engagement::{StepEngagement, StepKind, Z_TOL_MM};
pub use error::StockError;
pub use heightmap::read_height_map;
pub use motion::Move;
pub use spec::{load_stock, BoxSpec, HeightMapSpec, StockFile};
pub use sweep::{MoveSummary, Sweep, SweepOptions};
pub use zigzag::{zigzag_pocket, ZigZag};
pub use zmap::{Removal, ZMap};

//! Physical models of linear time-periodic (LTP) machines, each built into a
//! [`PeriodicSystem`](crate::system::PeriodicSystem): the gear pair (Eqs 36-46, with its mesh-stiffness and
//! tooth-fault builders), the forging-press cam mechanism (Eqs 32-35), the generic second-order system with
//! Fourier or piecewise-constant entries, the output quantity a scene reports, and the catalog of problems
//! with exact answers. Models never call solver internals.

pub mod catalog;
pub mod gear;
pub mod gear_train;
pub mod kinematics;
pub mod output;
pub mod press;
pub mod second_order;

pub use gear::{GearPair, GearPairParams, MeshStiffness};
pub use output::{OutputQuantity, Quantity};
pub use press::PressParams;
pub use second_order::SecondOrderSystem;

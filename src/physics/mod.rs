//! The physics core: pure functions of validated input. No I/O, no FMI, no
//! printing, and only safe Rust (raw pointers live in src/fmi/export.rs alone).

pub mod accuracy;
pub mod dynamic_wear;
pub mod dynamics;
pub mod gear;
pub mod hertz;
pub mod involute;
pub mod iso6336;
pub mod ltca;
pub mod lumped;
pub mod mesh;
pub mod modes;
pub mod order_tracking;
pub mod profile;
pub mod response;
pub mod separation;
pub mod simulation;
pub mod spectrum;
pub mod state_format;
pub mod stiffness;
pub mod wear;
pub mod wear_state;

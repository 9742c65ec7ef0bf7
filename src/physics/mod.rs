//! The physics core: pure functions of validated input. No I/O, no FMI, no
//! printing, no `unsafe`.

pub mod gear;
pub mod involute;
pub mod mesh;
pub mod profile;
pub mod separation;
pub mod hertz;
pub mod iso6336;
pub mod stiffness;
pub mod ltca;

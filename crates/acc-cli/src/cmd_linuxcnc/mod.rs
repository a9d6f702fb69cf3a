//! acc on LinuxCNC: `acc linuxcnc-process` (the simulated cutting process as a HAL
//! component, [`process`], its model in [`cut`]).

pub mod cut;
pub mod process;

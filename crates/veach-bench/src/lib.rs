//! Measuring veach: `bench` (error against render time per setting, its report and plots, `run`),
//! `scale` (render time as triangles and lights grow) and `mitsuba` (a scene written for Mitsuba 3,
//! for the peer comparison). Everything here drives the renderer through its public interface.

pub mod bench;
pub mod mitsuba;
pub mod run;
pub mod scale;

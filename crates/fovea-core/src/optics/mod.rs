//! Human-eye optics: the thin-lens eye and its depth of field (Liu et al. Eq. 4–9, 12–13),
//! pupil diameter from light level, Liu's DOF sampling weight and Russian roulette
//! (Eq. 10–11), and Weier et al.'s tracking-aware circle of confusion (Eq. 3).
//!
//! Distances are in metres at the API; the eye's internal lengths in millimetres. Signed
//! circles of confusion are negative in the near field (in front of the focus) and positive in
//! the far field.

pub mod accommodation;
pub mod dof_weight;
pub mod gaze_depth;
pub mod pupil;
pub mod thin_lens;
pub mod tracking_coc;

pub use accommodation::{AccommodationFilter, AccommodationParams};
pub use dof_weight::{dof_weight, russian_roulette, DEFAULT_MAX_DEPTH_M};
pub use gaze_depth::{
    estimate_gaze_depth, estimate_gaze_depth_with_prior, vergence_distance, GazeDepth,
    GazeDepthParams, Vergence,
};
pub use pupil::{pupil_de_groot_gebhard, pupil_liu_linear};
pub use thin_lens::{DofLimits, EyeModel, LiuDofCoefficients};
pub use tracking_coc::TrackingAwareCoc;

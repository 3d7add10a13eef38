//! derma-rig: dynamic facial colour, the skin appearance rig of Jimenez et al. 2010
//! ("A Practical Appearance Model for Dynamic Facial Color", ACM TOG 29(6)).
//!
//! Hemoglobin changes with expression, emotion and physiological state are coded as local
//! histogram matching of a neutral hemoglobin map (§4): per target, the local mean and spread
//! in a disk of radius r ([`local_stats`]) become a bias and a scale ([`basis`]), blended by the
//! same weights that drive the blend shapes ([`weights`], [`evaluate`]) and turned into colour by
//! the skin-colour LUT of derma-shading, which comes from derma's own Monte Carlo skin (eq. 7).
//!
//! Data flow: neutral map + targets (maps or the built-in [`expression`] library) →
//! [`basis::Rig::build`] → [`rig_dir::save`] (run-time textures + rig.json) →
//! [`evaluate::hemoglobin`] / [`evaluate::color`] per frame ([`evaluate_frame`] on the CPU or
//! the GPU), or [`evaluate::FramePlan`] for real-time frames; [`animation`] samples keyframed
//! weight curves and [`sequence`] renders them to a resumable image sequence; [`from_files`]
//! builds a rig directory from files, [`maps`] reads and writes the maps, [`preview`] shows a
//! frame on the built-in head.

#![warn(missing_docs)]

pub mod animation;
pub mod basis;
pub mod error;
pub mod evaluate;
pub mod expression;
pub mod frame_job;
pub mod from_files;
#[cfg(feature = "gpu")]
pub mod gpu_eval;
pub mod local_stats;
pub mod maps;
pub mod preview;
pub mod rig_dir;
pub mod sequence;
pub mod skin_response;
pub mod upsample;
pub mod weights;

pub use basis::{BasisOptions, Rig, TargetSource, TargetSpec, TransferMode};
pub use error::{Result, RigError};
pub use evaluate::{evaluate_frame, FramePlan};
pub use sequence::{render_sequence, SequenceOptions};
pub use weights::{GlobalScale, Normalization, WeightSpec};

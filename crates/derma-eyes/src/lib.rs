//! The eye region, after the EyeMove thesis ("Eye Region Animation and Screen-Space Distance
//! Fields", ch. 3–4; `../shared/seeds`):
//!
//! - [`gaze`]: the generalised gaze vector (Fick angles, lid openings, action units).
//! - [`region`], [`lids`], [`tracked`]: the head's eye region, lid curves and the tracked-data
//!   format; [`rigdata`] makes training data from the head's face units.
//! - [`pca`], [`regression`], [`model`]: the eyelid-shape and skin-motion models (eqs. 3.2–3.11);
//!   [`transfer`] moves them to other vertices (eqs. 3.4–3.5).
//! - [`contact`], [`depth`], [`globe`], [`sliding`], [`evaluate`]: the lids' contact, depth and
//!   normals learnt from the rig (in place of the thesis's skull map), the eyeball with its
//!   corneal bulge and globe sliding (Algorithm 1) that turn a model frame into 3D; [`surface`]
//!   carries it onto a user's own mesh through a fitted head (eq. 3.4).
//! - [`still`], [`live`]: one frame for a posed head (`derma render --gaze`), and the bound
//!   model as data for a real-time evaluator (the web viewer).
//! - [`blink`], [`saccade`], [`idle`], [`saliency`]: the drivers — stochastic blinks, main-sequence
//!   saccades, idle gaze and salient gaze targets; [`animate`] turns them into frames and
//!   [`synthetic`] into noisy tracked sequences.
//! - [`sdf`]: screen-space distance fields and the lacrimal lake (ch. 4).
//!
//! Units are millimetres and degrees; the head looks down +Z with +Y up.

#![warn(missing_docs)]

pub mod animate;
pub mod blink;
pub mod contact;
pub mod depth;
pub mod error;
pub mod evaluate;
pub mod files;
pub mod gaze;
pub mod glb;
pub mod globe;
pub mod idle;
pub mod lids;
pub mod live;
pub mod model;
pub mod pca;
pub mod region;
pub mod regression;
pub mod render;
pub mod rigdata;
pub mod saccade;
pub mod saliency;
pub mod sdf;
pub mod sliding;
pub mod still;
pub mod surface;
pub mod synthetic;
pub mod tracked;
pub mod transfer;

pub use error::{EyesError, Result};
pub use gaze::{Fick, Gaze};
pub use model::{Components, EyeModel};

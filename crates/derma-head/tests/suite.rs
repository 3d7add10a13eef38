//! The integration tests of derma-head as one test binary (one build and link instead of one per
//! file; `cargo test -p derma-head --test suite FILE::` runs one file's tests).

mod corpus;
mod corpus_face_units;
mod fit;
mod head;
mod robust_fitted;
mod robust_landmarks;

#[path = "support/truth.rs"]
#[allow(dead_code)]
mod truth;

//! `derma check SET`: is a texture set what its manifest says it is (derma-skin's manifest):
//! every listed file present with its SHA-256, nothing unlisted beside them.

use anyhow::{bail, Result};
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct CheckArgs {
    /// The set's directory (holding manifest.json).
    set: PathBuf,
}

pub fn run(args: CheckArgs) -> Result<()> {
    let f = derma_skin::manifest::check(&args.set)?;
    let list = |what: &str, v: &[String]| {
        if !v.is_empty() {
            let _ = crate::output::line(format!("{what}: {}", v.join(", ")));
        }
    };
    list("missing", &f.missing);
    list("changed", &f.changed);
    list("not in the manifest", &f.unlisted);
    if !f.ok() {
        bail!(
            "'{}' is not the set its manifest describes ({} files as written)",
            args.set.display(),
            f.intact
        );
    }
    crate::output::line(format!(
        "{}: {} files as written",
        args.set.display(),
        f.intact
    ))
}

//! `ghm compile`: a controller of `ghm mpc`, `ghm rlmpc`, `ghm policy` or the expert as a
//! static library with a C ABI, its model, networks and options built in (`embed`). The
//! controller flags are `ghm serve`'s; this file maps them onto a spec and the folder.

use crate::cli::serve::ControllerArgs;
use crate::cli::CliError;
use crate::embed::package::{link_flags, write_package, PackageOptions};
use crate::embed::{Bundle, EmbedError};
use clap::Args;
use std::path::PathBuf;

#[derive(Debug, Args)]
pub struct CompileArgs {
    #[command(flatten)]
    pub controller: ControllerArgs,
    /// The folder to write: include/ghm_controller.h, lib/libghm_controller.a, the bundle.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// ghm's runtime library (default: libghm.a beside this ghm binary, which
    /// `cargo build --release` builds).
    #[arg(long, value_name = "FILE")]
    pub runtime: Option<PathBuf>,
    /// The C compiler for the bundle's source file (default: $CC, else cc).
    #[arg(long, value_name = "CC")]
    pub cc: Option<String>,
    /// The archiver that adds it to the library (default: $AR, else ar).
    #[arg(long, value_name = "AR")]
    pub ar: Option<String>,
    /// Replace a folder that holds other files.
    #[arg(long)]
    pub overwrite: bool,
}

pub fn run(args: &CompileArgs) -> Result<(), CliError> {
    let spec = args.controller.spec()?;
    let bundle = Bundle::from_spec(&spec).map_err(embed_error)?;
    let tool = |given: &Option<String>, var: &str, default: &str| {
        given
            .clone()
            .or_else(|| std::env::var(var).ok().filter(|v| !v.is_empty()))
            .unwrap_or_else(|| default.into())
    };
    let options = PackageOptions {
        out: args.out.clone(),
        runtime: args.runtime.clone(),
        cc: tool(&args.cc, "CC", "cc"),
        ar: tool(&args.ar, "AR", "ar"),
        overwrite: args.overwrite,
    };
    let package = write_package(&bundle, &options).map_err(embed_error)?;
    println!(
        "compiled {} ({} bytes of model, networks and options) into {}",
        spec.model.display(),
        package.bundle_bytes,
        package.library.display()
    );
    println!("header:   {}", package.header.display());
    println!(
        "link with: cc -I {} prog.c -L {} {}",
        args.out.join("include").display(),
        args.out.join("lib").display(),
        link_flags()
    );
    Ok(())
}

/// An embedding error as the command line's.
fn embed_error(e: EmbedError) -> CliError {
    match e {
        EmbedError::Job(j) => CliError::Job(j),
        other => CliError::Embed(other),
    }
}

//! `momo rig import`: a rig.json from an OpenCV, ROS or Kalibr calibration file
//! (`momo_io::calib_import`, docs/CAMERAS.md).

use crate::common::Failure;
use momo_io::calib_import::{import_calibration, parse_mount};
use std::path::PathBuf;

/// The subcommands of `momo rig`.
#[derive(clap::Subcommand, Debug)]
pub(crate) enum RigCommand {
    /// Write rig.json from a calibration file: OpenCV FileStorage YAML (camera_matrix,
    /// distortion_coefficients), ROS camera_info YAML, or a Kalibr camchain (cam0..camN with
    /// T_cn_cnm1). The format is recognised by its keys.
    #[command(
        after_help = "Example:\n  momo rig import camchain.yaml -o seq/rig.json --mount 1.5,0,1.3,0,5\n\n\
        --mount places camera 0 on the vehicle (x forward, y left, z up, metres; yaw 0 = forward, \
        90 = left; pitch = downward tilt, degrees); the other cameras of a Kalibr chain follow \
        from T_cn_cnm1. Without it camera 0 looks forward, level, at the vehicle origin."
    )]
    Import(ImportArgs),
}

/// The arguments of `momo rig import`.
#[derive(clap::Args, Debug)]
pub(crate) struct ImportArgs {
    /// The calibration file (YAML).
    calibration: PathBuf,
    /// Output rig.json (written atomically).
    #[arg(short, long)]
    output: PathBuf,
    /// T_vehicle_camera of camera 0: `x,y,z[,yaw_deg[,pitch_down_deg]]` or 16 numbers (the
    /// 4x4 matrix row by row). Default: level, forward-looking, at the vehicle origin.
    #[arg(long, default_value = "0,0,0", allow_hyphen_values = true)]
    mount: String,
    /// Print nothing on success.
    #[arg(short, long)]
    quiet: bool,
}

/// `momo rig ...`.
pub(crate) fn rig(command: RigCommand) -> Result<(), Failure> {
    match command {
        RigCommand::Import(args) => import(args),
    }
}

fn import(args: ImportArgs) -> Result<(), Failure> {
    crate::common::check_outputs(&[args.calibration.as_path()], &[args.output.as_path()])?;
    let mount = parse_mount(&args.mount).map_err(|e| Failure::Input(anyhow::anyhow!(e)))?;
    let (rig, format) = import_calibration(&args.calibration, &mount).map_err(Failure::input)?;
    momo_io::write_rig(&args.output, &rig).map_err(Failure::other)?;
    if !args.quiet {
        let models: Vec<String> = rig
            .cameras()
            .iter()
            .map(|c| {
                let tag = serde_json::to_value(c.model)
                    .ok()
                    .and_then(|v| v.get("type").and_then(|t| t.as_str()).map(str::to_owned))
                    .unwrap_or_default();
                format!("{} ({tag})", c.name)
            })
            .collect();
        note!(
            "momo: {format}: {} camera(s): {}; wrote {}",
            rig.len(),
            models.join(", "),
            args.output.display()
        );
    }
    Ok(())
}

//! Snapshot writers (sinks): extended XYZ (OVITO, ASE) and Parquet, one file each per time.

use std::fmt::Write as _;
use std::path::Path;

use nalgebra::Vector3;

use super::cloud::{centre_of_mass, Cloud};
use crate::output::atomic::write_atomic;
use crate::output::plot::{render_png_sized, Figure, Series, SeriesStyle};
use crate::output::table::{write_parquet, ColumnData, Table};
use crate::Result;

/// Extended XYZ text of a cloud at time `time` (s): species, position (m), velocity (m/s),
/// radius (m), charge per mass (C/kg), spin (rad/s).
pub fn extended_xyz(cloud: &Cloud, time: f64) -> String {
    let mut text = format!(
        "{}\nProperties=species:S:1:pos:R:3:velo:R:3:radius:R:1:charge_per_mass:R:1:spin:R:3 Time={time:e} pbc=\"F F F\"\n",
        cloud.len()
    );
    for i in 0..cloud.len() {
        let (r, v, w) = (cloud.positions[i], cloud.velocities[i], cloud.spins[i]);
        let _ = writeln!(
            text,
            "P {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e} {:e}",
            r.x, r.y, r.z, v.x, v.y, v.z, cloud.radius, cloud.charge_per_mass[i], w.x, w.y, w.z
        );
    }
    text
}

/// The same snapshot as a table (one row per particle).
pub fn table(cloud: &Cloud) -> Table {
    let col = |f: &dyn Fn(usize) -> f64| ColumnData::F64((0..cloud.len()).map(f).collect());
    Table::new()
        .with("id", ColumnData::U64((0..cloud.len() as u64).collect()))
        .with("x_m", col(&|i| cloud.positions[i].x))
        .with("y_m", col(&|i| cloud.positions[i].y))
        .with("z_m", col(&|i| cloud.positions[i].z))
        .with("vx_m_per_s", col(&|i| cloud.velocities[i].x))
        .with("vy_m_per_s", col(&|i| cloud.velocities[i].y))
        .with("vz_m_per_s", col(&|i| cloud.velocities[i].z))
        .with("radius_m", col(&|_| cloud.radius))
        .with(
            "charge_per_mass_C_per_kg",
            col(&|i| cloud.charge_per_mass[i]),
        )
}

/// Side view of the cloud: particle centres projected on the plane spanned by the field axis
/// (horizontal) and a perpendicular axis, both relative to the centre of mass, on equal
/// ranges so the shape is not distorted (rendered square).
pub fn side_view(cloud: &Cloud, axis: &Vector3<f64>, time: f64) -> Figure {
    let other = if axis.cross(&Vector3::z()).norm() > 0.1 {
        Vector3::z()
    } else {
        Vector3::y()
    };
    let across = (other - other.dot(axis) * axis).normalize();
    let c = centre_of_mass(&cloud.positions);
    let x: Vec<f64> = cloud.positions.iter().map(|r| (r - c).dot(axis)).collect();
    let y: Vec<f64> = cloud
        .positions
        .iter()
        .map(|r| (r - c).dot(&across))
        .collect();
    let reach = x.iter().chain(&y).fold(cloud.radius, |m, v| m.max(v.abs()));
    let frame = Series {
        label: String::new(),
        x: vec![-reach, reach],
        y: vec![-reach, reach],
        y_err: None,
        style: SeriesStyle::Line,
    };
    Figure {
        title: format!("t = {time:.3} s, {} particles", cloud.len()),
        x_label: "along B (m)".into(),
        y_label: "across B (m)".into(),
        series: vec![
            Series {
                label: "particle centres".into(),
                x,
                y,
                y_err: None,
                style: SeriesStyle::Points,
            },
            Series {
                style: SeriesStyle::Points,
                ..frame
            },
        ],
        ..Default::default()
    }
}

/// Writes `snapshot_<k>_t<time>s.xyz`, `.parquet` and a side view `.png` into `dir` (which
/// must exist); `axis` is the unit field axis.
pub fn write(dir: &Path, k: usize, time: f64, cloud: &Cloud, axis: &Vector3<f64>) -> Result<()> {
    let stem = format!("snapshot_{k:03}_t{time:.4}s");
    write_atomic(
        &dir.join(format!("{stem}.xyz")),
        extended_xyz(cloud, time).as_bytes(),
    )?;
    write_parquet(&dir.join(format!("{stem}.parquet")), &table(cloud))?;
    render_png_sized(
        &dir.join(format!("{stem}.png")),
        &side_view(cloud, axis, time),
        800,
        800,
    )
}

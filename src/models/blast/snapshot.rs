//! Snapshot writers (sinks): the cloud as a particle frame (extended XYZ, LAMMPS dump, legacy
//! VTK and Parquet, see [`crate::output::particles`]) and a side view PNG, one set per time.

use nalgebra::Vector3;

use super::cloud::{centre_of_mass, Cloud};
use crate::output::particles::{Cell, ParticleFrame, Property};
use crate::output::plot::{render_png_sized, Figure, Series, SeriesStyle};
use crate::output::snapshots::Recorder;

/// The cloud at time `time` (s) as a particle frame: type 1 for particles with q/m ≥ 0,
/// type 2 for q/m < 0; the cell is the bounding box of the spheres (not periodic); extra
/// columns `charge_per_mass` (C/kg) and `angular_velocity` (rad/s).
pub fn frame(cloud: &Cloud, time: f64) -> ParticleFrame {
    let radius = vec![cloud.radius; cloud.len()];
    let cell = Cell::bounding(&cloud.positions, &radius);
    let kind = cloud
        .charge_per_mass
        .iter()
        .map(|q| if *q < 0.0 { 2 } else { 1 })
        .collect();
    let mut frame = ParticleFrame::new(time, cell, kind);
    frame.position = cloud.positions.clone();
    frame.velocity = cloud.velocities.clone();
    frame.radius = radius;
    frame.mass = vec![cloud.mass; cloud.len()];
    let q = cloud.charge_per_mass.clone();
    frame
        .with(Property::scalar("charge_per_mass", "C_per_kg", q))
        .with(Property::vector(
            "angular_velocity",
            "rad_per_s",
            cloud.spins.clone(),
        ))
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

/// Writes a moment of the run (`<label>.*` in the recorder's formats) and its side view
/// `<label>.png`; `axis` is the unit field axis.
pub fn moment(
    recorder: &mut Recorder,
    label: &str,
    step: u64,
    time: f64,
    cloud: &Cloud,
    axis: &Vector3<f64>,
) {
    recorder.moment(label, step, &frame(cloud, time));
    recorder.attempt(|dir| {
        let path = dir.join(format!("{label}.png"));
        render_png_sized(&path, &side_view(cloud, axis, time), 800, 800)
    });
}

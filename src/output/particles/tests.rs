//! Round trips of every format.

use nalgebra::Vector3;

use super::*;
use crate::output::table::{read_parquet, ColumnData};

/// A frame with awkward floats, two types and one scalar and one vector extra column.
fn sample() -> ParticleFrame {
    let n = 5;
    let f = |k: usize, s: f64| (k as f64 * 0.37 + s).sin() * 10f64.powi(k as i32 - 3);
    let lo = Vector3::new(-0.1, -2e-3, -1.0 / 3.0);
    let mut cell = Cell::aligned(lo, Vector3::new(0.7, 0.2, 1e-3));
    cell.pbc = [true, false, false];
    let mut frame = ParticleFrame::new(1.0 / 7.0, cell, (0..n).map(|k| 1 + k as u32 % 2).collect());
    for k in 0..n {
        frame.position[k] = Vector3::new(f(k, 0.1), f(k, 0.2), f(k, 0.3));
        frame.velocity[k] = Vector3::new(f(k, 1.1), -f(k, 1.2), f(k, 1.3));
        frame.radius[k] = 1e-3 + f(k, 2.0).abs();
        frame.mass[k] = 7.8e-6 * (1.0 + k as f64 / 3.0);
    }
    frame
        .with(Property::scalar(
            "force_magnitude",
            "N",
            (0..n).map(|k| f(k, 3.0)).collect(),
        ))
        .with(Property::vector(
            "angular_velocity",
            "rad_per_s",
            (0..n)
                .map(|k| Vector3::new(f(k, 4.0), f(k, 5.0), 1e300))
                .collect(),
        ))
        .with(Property::scalar(
            "cos_theta",
            "1",
            (0..n).map(|k| f(k, 6.0).abs()).collect(),
        ))
}

/// The frame as a reader without units or species symbols returns it.
fn without_units(mut frame: ParticleFrame) -> ParticleFrame {
    frame.extra.iter_mut().for_each(|p| p.unit.clear());
    frame
}

#[test]
fn extended_xyz_round_trips_bit_exact() {
    let frame = sample();
    let text = extended_xyz(&frame);
    assert_eq!(read_xyz(&text, 0).unwrap(), frame);
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!((lines[0], lines.len()), ("5", 7));
    assert!(lines[1].contains("pbc=\"T F F\""));
    assert!(lines[1].contains(
        "Properties=type:I:1:species:S:1:pos:R:3:radius:R:1:velo:R:3:masses:R:1:momenta:R:3:\
         force_magnitude:R:1:angular_velocity:R:3:cos_theta:R:1 "
    ));
}

#[test]
fn extended_xyz_frames_are_chosen_by_index() {
    let first = sample();
    let mut second = sample();
    second.time = 2.5;
    second.position[0].x = 0.125;
    let text = extended_xyz(&first) + &extended_xyz(&second);
    assert_eq!(read_xyz(&text, 0).unwrap(), first);
    assert_eq!(read_xyz(&text, 1).unwrap(), second);
    assert_eq!(read_xyz(&text, -1).unwrap(), second);
    assert!(read_xyz(&text, 2).is_err());
    assert_eq!(xyz_frame_count(&text).unwrap(), 2);
}

#[test]
fn an_extended_xyz_count_near_the_integer_limit_is_a_short_frame() {
    for count in [usize::MAX, usize::MAX - 1, usize::MAX - 3] {
        let text = format!("{count}\ncomment\n1 2 3\n");
        assert_eq!(xyz_frame_count(&text).unwrap(), 1);
        assert!(read_xyz(&text, 0).is_err());
    }
}

#[test]
fn lammps_dump_round_trips_bit_exact() {
    let frame = sample();
    let text = lammps_dump(&frame, 3).unwrap();
    assert_eq!(read_lammps_dump(&text).unwrap(), without_units(frame));
    assert!(text.contains("ITEM: TIMESTEP\n3\n"));
    assert!(text.contains("ITEM: BOX BOUNDS pp ff ff\n"));
    assert!(text.contains(
        "ITEM: ATOMS id type x y z radius vx vy vz mass force_magnitude \
         angular_velocity_x angular_velocity_y angular_velocity_z cos_theta\n"
    ));
}

#[test]
fn lammps_dump_refuses_a_tilted_cell() {
    let mut frame = sample();
    frame.cell.vectors[1].x = 0.1;
    assert!(lammps_dump(&frame, 0).is_err());
}

#[test]
fn legacy_vtk_holds_points_vertices_and_point_data() {
    let frame = sample();
    let text = legacy_vtk(&frame);
    for part in [
        "DATASET POLYDATA\n",
        "FIELD FieldData 4\nTIME 1 1 double\n",
        "PBC 3 1 int\n1 0 0\n",
        "POINTS 5 double\n",
        "VERTICES 5 10\n1 0\n",
        "POINT_DATA 5\nSCALARS radius double 1\nLOOKUP_TABLE default\n",
        "VECTORS velocity double\n",
        "FIELD FieldData 6\nid 1 5 long\n1\n2\n",
        "type 1 5 int\n1\n2\n1\n",
        "force_magnitude 1 5 double\n",
        "angular_velocity 3 5 double\n",
    ] {
        assert!(text.contains(part), "{part}");
    }
    let at = text
        .find("SCALARS radius double 1\nLOOKUP_TABLE default\n")
        .unwrap();
    let first: f64 = text[at..].lines().nth(2).unwrap().parse().unwrap();
    assert_eq!(first, frame.radius[0]);
}

#[test]
fn parquet_table_round_trips_with_unit_suffixes() {
    let frame = sample();
    let dir = std::env::temp_dir().join(format!("magopt-particles-pq-{}", std::process::id()));
    frame.write_all(&dir, "snapshot.000").unwrap();
    let t = read_parquet(&dir.join("snapshot.000.parquet")).unwrap();
    assert_eq!(t, table(&frame));
    let f64s = |name: &str| match t.column(name) {
        Some(ColumnData::F64(v)) => v.clone(),
        other => panic!("{name}: {other:?}"),
    };
    assert_eq!(f64s("x_m")[2], frame.position[2].x);
    assert_eq!(f64s("vz_m_per_s")[4], frame.velocity[4].z);
    assert_eq!(f64s("radius_m"), frame.radius);
    assert_eq!(f64s("force_magnitude_N")[1], frame.extra[0].get(1, 0));
    assert_eq!(
        f64s("angular_velocity_y_rad_per_s")[3],
        frame.extra[1].get(3, 1)
    );
    assert_eq!(
        t.column("type"),
        Some(&ColumnData::I64(vec![1, 2, 1, 2, 1]))
    );
    for ext in ["xyz", "dump", "vtk"] {
        assert!(dir.join(format!("snapshot.000.{ext}")).exists(), "{ext}");
    }
    let xyz = std::fs::read_to_string(dir.join("snapshot.000.xyz")).unwrap();
    assert_eq!(read_xyz(&xyz, 0).unwrap(), frame);
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn bounding_box_encloses_the_spheres() {
    let p = [Vector3::new(0.0, 1.0, -1.0), Vector3::new(2.0, -1.0, 0.5)];
    let cell = Cell::bounding(&p, &[0.5, 0.25]);
    assert_eq!(cell.origin, Vector3::new(-0.5, -1.25, -1.5));
    assert_eq!(cell.vectors[0].x, 2.75);
    assert_eq!(cell.vectors[2].z, 2.25);
    assert_eq!(cell.pbc, [false; 3]);
}

#[test]
fn legacy_vtk_round_trips_bit_exact() {
    let frame = sample();
    assert_eq!(read_vtk(&legacy_vtk(&frame)).unwrap(), without_units(frame));
}

#[test]
fn parquet_particle_table_round_trips_whole() {
    let frame = sample();
    let dir = std::env::temp_dir().join(format!("magopt-particles-rt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("frame.parquet");
    write_particle_table(&path, &frame).unwrap();
    assert_eq!(read_particle_table(&path).unwrap(), frame);
    let t = read_parquet(&path).unwrap();
    assert!(t.column("cos_theta").is_some(), "dimensionless: no suffix");
    assert_eq!(t.unit("angular_velocity_x_rad_per_s"), Some("rad/s"));
    assert_eq!(t.unit("x_m"), Some("m"));
    std::fs::remove_dir_all(dir).ok();
}

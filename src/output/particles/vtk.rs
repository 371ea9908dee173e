//! Legacy VTK POLYDATA (ParaView): the particles as POINTS (m) with one VERTICES cell each,
//! the time (s) as field data `TIME`, and POINT_DATA `id`, `type`, `radius` (m, the scalar to
//! scale sphere glyphs by), `velocity` (m/s), `mass` (kg) and the extra columns (scalars or vectors).

use std::fmt::Write as _;

use nalgebra::Vector3;

use super::{ParticleFrame, Values};

/// One frame as legacy VTK text.
pub fn legacy_vtk(frame: &ParticleFrame) -> String {
    let n = frame.len();
    let mut text = format!(
        "# vtk DataFile Version 3.0\nmagopt particles, t = {:?} s, SI units\nASCII\n\
         DATASET POLYDATA\nFIELD FieldData 1\nTIME 1 1 double\n{:?}\nPOINTS {n} double\n",
        frame.time, frame.time
    );
    vectors_body(&mut text, &frame.position);
    let _ = writeln!(text, "VERTICES {n} {}", 2 * n);
    for i in 0..n {
        let _ = writeln!(text, "1 {i}");
    }
    let _ = writeln!(text, "POINT_DATA {n}");
    scalars(&mut text, "id", "long", &frame.id);
    scalars(&mut text, "type", "int", &frame.kind);
    scalars(&mut text, "radius", "double", &frame.radius);
    vectors(&mut text, "velocity", &frame.velocity);
    scalars(&mut text, "mass", "double", &frame.mass);
    for p in &frame.extra {
        match &p.values {
            Values::Scalar(v) => scalars(&mut text, &p.name, "double", v),
            Values::Vector(v) => vectors(&mut text, &p.name, v),
        }
    }
    text
}

/// A SCALARS block; `{:?}` prints integers as integers and floats so they read back exactly.
fn scalars<T: std::fmt::Debug>(text: &mut String, name: &str, kind: &str, values: &[T]) {
    let _ = writeln!(text, "SCALARS {name} {kind} 1\nLOOKUP_TABLE default");
    for v in values {
        let _ = writeln!(text, "{v:?}");
    }
}

fn vectors(text: &mut String, name: &str, values: &[Vector3<f64>]) {
    let _ = writeln!(text, "VECTORS {name} double");
    vectors_body(text, values);
}

fn vectors_body(text: &mut String, values: &[Vector3<f64>]) {
    for v in values {
        let _ = writeln!(text, "{:?} {:?} {:?}", v.x, v.y, v.z);
    }
}

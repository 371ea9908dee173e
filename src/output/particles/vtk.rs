//! Legacy VTK POLYDATA (ParaView): the particles as POINTS (m) with one VERTICES cell each,
//! field data `TIME` (s), `ORIGIN` and `LATTICE` (the cell, m: origin, then a, b, c) and `PBC`
//! (1 = periodic along a, b, c), and POINT_DATA: `radius` (m, the active scalars that sphere
//! glyphs scale by), `velocity` (m/s, the active vectors), and a FIELD block with `id`, `type`,
//! `mass` (kg) and the extra columns (1 or 3 components).
//! [`read_vtk`] reads it back (the extra columns without their units, which VTK has no place
//! for; `docs/particle-files.md` lists them).

use std::fmt::Write as _;

use nalgebra::Vector3;

use super::{number, Cell, ParticleFrame, Property};
use crate::{Error, Result};

/// One frame as legacy VTK text.
pub fn legacy_vtk(frame: &ParticleFrame) -> String {
    let n = frame.len();
    let c = &frame.cell;
    let v = |x: &Vector3<f64>| format!("{:?} {:?} {:?}", x.x, x.y, x.z);
    let lattice: Vec<String> = c.vectors.iter().map(v).collect();
    let pbc: Vec<&str> = c.pbc.iter().map(|p| if *p { "1" } else { "0" }).collect();
    let mut text = format!(
        "# vtk DataFile Version 3.0\nmagopt particles, t = {:?} s, SI units\nASCII\n\
         DATASET POLYDATA\nFIELD FieldData 4\nTIME 1 1 double\n{:?}\nORIGIN 3 1 double\n{}\n\
         LATTICE 9 1 double\n{}\nPBC 3 1 int\n{}\nPOINTS {n} double\n",
        frame.time,
        frame.time,
        v(&c.origin),
        lattice.join(" "),
        pbc.join(" ")
    );
    vectors_body(&mut text, &frame.position);
    let _ = writeln!(text, "VERTICES {n} {}", 2 * n);
    for i in 0..n {
        let _ = writeln!(text, "1 {i}");
    }
    let _ = writeln!(text, "POINT_DATA {n}");
    // radius first (the active scalars, which glyph filters scale by), velocity the active
    // vectors; everything else in a FIELD block, which VTK's readers always load (they load
    // only the first SCALARS and VECTORS blocks unless told otherwise).
    scalars(&mut text, "radius", "double", &frame.radius);
    vectors(&mut text, "velocity", &frame.velocity);
    let _ = writeln!(text, "FIELD FieldData {}", 3 + frame.extra.len());
    array(
        &mut text,
        "id",
        1,
        "long",
        frame.id.iter().map(|x| format!("{x}")),
    );
    array(
        &mut text,
        "type",
        1,
        "int",
        frame.kind.iter().map(|x| format!("{x}")),
    );
    array(
        &mut text,
        "mass",
        1,
        "double",
        frame.mass.iter().map(|x| format!("{x:?}")),
    );
    for p in &frame.extra {
        let rows = (0..frame.len()).map(|i| {
            let c: Vec<String> = (0..p.components())
                .map(|k| format!("{:?}", p.get(i, k)))
                .collect();
            c.join(" ")
        });
        array(&mut text, &p.name, p.components(), "double", rows);
    }
    text
}

/// A FIELD array of one row per particle.
fn array(
    text: &mut String,
    name: &str,
    components: usize,
    kind: &str,
    rows: impl ExactSizeIterator<Item = String>,
) {
    let _ = writeln!(text, "{name} {components} {} {kind}", rows.len());
    for row in rows {
        let _ = writeln!(text, "{row}");
    }
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

/// The words of a legacy VTK file after its three header lines.
struct Words<'a>(Box<dyn Iterator<Item = &'a str> + 'a>);

impl<'a> Words<'a> {
    fn next(&mut self) -> Result<&'a str> {
        self.0
            .next()
            .ok_or_else(|| Error::input("VTK file is cut short"))
    }

    fn count(&mut self) -> Result<usize> {
        count(self.next()?)
    }

    fn numbers(&mut self, n: usize) -> Result<Vec<f64>> {
        (0..n).map(|_| number(self.next()?)).collect()
    }
}

/// Reads a file written by [`legacy_vtk`].
pub fn read_vtk(text: &str) -> Result<ParticleFrame> {
    let mut w = Words(Box::new(
        text.lines().skip(3).flat_map(str::split_whitespace),
    ));
    let (mut time, mut cell) = (0.0, Cell::aligned(Vector3::zeros(), Vector3::zeros()));
    let mut frame: Option<ParticleFrame> = None;
    while let Some(word) = w.0.next() {
        match word {
            "DATASET" | "POINT_DATA" => {
                w.next()?;
            }
            "FIELD" => {
                w.next()?;
                for _ in 0..w.count()? {
                    let name = w.next()?.to_string();
                    let (c, t) = (w.count()?, w.count()?);
                    w.next()?;
                    let x = w.numbers(c * t)?;
                    match frame.as_mut() {
                        Some(f) => point_data(f, name, c, &x),
                        None => field(&name, &x, &mut time, &mut cell),
                    }
                }
            }
            "POINTS" => {
                let n = w.count()?;
                w.next()?;
                let x = w.numbers(3 * n)?;
                let mut f = ParticleFrame::new(time, cell.clone(), vec![1; n]);
                f.position = x.chunks(3).map(Vector3::from_column_slice).collect();
                frame = Some(f);
            }
            "VERTICES" => {
                w.next()?;
                let entries = w.count()?;
                w.numbers(entries)?;
            }
            "SCALARS" | "VECTORS" => {
                let f = frame
                    .as_mut()
                    .ok_or_else(|| Error::input("VTK point data before POINTS"))?;
                let name = w.next()?.to_string();
                w.next()?;
                let components = if word == "SCALARS" {
                    let c = w.count()?;
                    w.next()?; // LOOKUP_TABLE
                    w.next()?; // default
                    c
                } else {
                    3
                };
                let x = w.numbers(components * f.len())?;
                point_data(f, name, components, &x);
            }
            other => return Err(Error::input(format!("unexpected VTK word '{other}'"))),
        }
    }
    frame.ok_or_else(|| Error::input("VTK file has no POINTS"))
}

fn count(word: &str) -> Result<usize> {
    word.parse()
        .map_err(|_| Error::input(format!("not a count: '{word}'")))
}

/// Applies a field-data array of the file header.
fn field(name: &str, x: &[f64], time: &mut f64, cell: &mut Cell) {
    match (name, x.len()) {
        ("TIME", 1) => *time = x[0],
        ("ORIGIN", 3) => cell.origin = Vector3::from_column_slice(x),
        ("LATTICE", 9) => {
            for (k, v) in cell.vectors.iter_mut().enumerate() {
                *v = Vector3::from_column_slice(&x[3 * k..3 * k + 3]);
            }
        }
        ("PBC", 3) => cell.pbc = [x[0] != 0.0, x[1] != 0.0, x[2] != 0.0],
        _ => {}
    }
}

/// Stores a POINT_DATA array in its column.
fn point_data(frame: &mut ParticleFrame, name: String, components: usize, x: &[f64]) {
    let vectors = || x.chunks(3).map(Vector3::from_column_slice).collect();
    match (name.as_str(), components) {
        ("id", 1) => frame.id = x.iter().map(|v| *v as u64).collect(),
        ("type", 1) => frame.kind = x.iter().map(|v| *v as u32).collect(),
        ("radius", 1) => frame.radius = x.to_vec(),
        ("mass", 1) => frame.mass = x.to_vec(),
        ("velocity", 3) => frame.velocity = vectors(),
        (_, 1) => frame.extra.push(Property::scalar(&name, "", x.to_vec())),
        _ => frame.extra.push(Property::vector(&name, "", vectors())),
    }
}

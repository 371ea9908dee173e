//! The single-particle diagnostics of the source (E&B 2020, §2.2): the moment's angle ψ(θ) for
//! several fields (its Fig. 2), the torque factor sin 2ψ versus H for several axis angles θ
//! (its Fig. 3a,b) and the field of maximum torque versus θ (its Fig. 3c), for any material,
//! as tables and figures. Everything follows from (A2)–(A3) (`stoner_wohlfarth`).

use crate::materials::Material;
use crate::output::plot::{Figure, Series, SeriesStyle};
use crate::output::table::{ColumnData, Table};
use crate::units::to_unit;

use super::stoner_wohlfarth::equilibrium;

/// Axis angles θ (degrees) of the torque-versus-field curves (both sides of 45°).
pub const TORQUE_ANGLES_DEG: [f64; 8] = [10.0, 30.0, 45.0, 55.0, 65.0, 75.0, 85.0, 89.0];
/// Points of each curve.
const CURVE_POINTS: usize = 181;

/// The reduced fields of the ψ(θ) curves when none are given: h = 0.25 … 5 (for Sr ferrite
/// ≈ 4.6–92 kOe, the source's range).
pub fn default_fields(material: &Material) -> Vec<f64> {
    [0.25, 0.5, 1.0, 2.0, 5.0]
        .iter()
        .map(|h| h * material.anisotropy_field())
        .collect()
}

/// ψ(θ) in degrees, θ from 0° to 90°, for each field (A/m): table and figure.
pub fn psi_vs_theta(material: &Material, fields: &[f64]) -> (Table, Figure) {
    let hk = material.anisotropy_field();
    let mut rows = Rows::default();
    let mut figure = figure(
        "ψ(θ): moment angle from the easy axis",
        "θ (deg)",
        "ψ (deg)",
    );
    for &field in fields {
        let h = field / hk;
        let theta: Vec<f64> = (0..CURVE_POINTS)
            .map(|k| 90.0 * k as f64 / (CURVE_POINTS - 1) as f64)
            .collect();
        let psi: Vec<f64> = theta
            .iter()
            .map(|t| {
                let t = t.to_radians();
                equilibrium(t.sin(), t.cos(), h).psi.to_degrees()
            })
            .collect();
        rows.add(&theta, field, h, &psi);
        figure.series.push(line(
            format!("{:.3} kOe", to_unit(field, "kOe")),
            theta,
            psi,
        ));
    }
    (rows.table("psi_deg"), figure)
}

/// The torque factor sin 2ψ (torque / K V, A3) versus H for each angle of
/// [`TORQUE_ANGLES_DEG`], H log-spaced over 0.01–100 H_K: table and figure (log field axis).
pub fn torque_vs_field(material: &Material) -> (Table, Figure) {
    let hk = material.anisotropy_field();
    let mut rows = Rows::default();
    let mut figure = figure("torque vs field", "H (kOe)", "T / (K V) = sin 2ψ");
    figure.log_x = true;
    let h: Vec<f64> = (0..CURVE_POINTS)
        .map(|k| 10f64.powf(-2.0 + 4.0 * k as f64 / (CURVE_POINTS - 1) as f64))
        .collect();
    let koe: Vec<f64> = h.iter().map(|h| to_unit(h * hk, "kOe")).collect();
    for deg in TORQUE_ANGLES_DEG {
        let t = deg.to_radians();
        let torque: Vec<f64> = h
            .iter()
            .map(|&h| equilibrium(t.sin(), t.cos(), h).torque_factor)
            .collect();
        for (k, &hk_mult) in h.iter().enumerate() {
            rows.push(deg, hk_mult * hk, hk_mult, torque[k]);
        }
        figure
            .series
            .push(line(format!("θ = {deg}°"), koe.clone(), torque));
    }
    (rows.table("torque_factor"), figure)
}

/// The reduced field of maximum torque for an axis at θ > 45°, found by golden-section search
/// of sin 2ψ(θ, h) over ln h (independent of the closed form h* = 1/(2 sin(θ − 45°))).
pub fn field_of_maximum_torque(theta: f64) -> f64 {
    let torque = |ln_h: f64| equilibrium(theta.sin(), theta.cos(), ln_h.exp()).torque_factor;
    let (mut a, mut b) = ((1e-3f64).ln(), (1e4f64).ln());
    let r = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..120 {
        let (c, d) = (b - r * (b - a), a + r * (b - a));
        if torque(c) > torque(d) {
            b = d;
        } else {
            a = c;
        }
    }
    (0.5 * (a + b)).exp()
}

/// The field of maximum torque versus θ over (45°, 90°): table (numerical and closed form) and
/// figure (field in kOe, log axis).
pub fn maximum_torque_field(material: &Material) -> (Table, Figure) {
    let hk = material.anisotropy_field();
    let theta: Vec<f64> = (1..=88).map(|k| 45.0 + 0.5 * k as f64).collect();
    let h: Vec<f64> = theta
        .iter()
        .map(|t| field_of_maximum_torque(t.to_radians()))
        .collect();
    let closed: Vec<f64> = theta
        .iter()
        .map(|t| 0.5 / (t - 45.0).to_radians().sin())
        .collect();
    let koe: Vec<f64> = h.iter().map(|h| to_unit(h * hk, "kOe")).collect();
    let table = Table::new()
        .with_unit("theta", ColumnData::F64(theta.clone()), "deg")
        .with("h_max", ColumnData::F64(h))
        .with("h_star_closed_form", ColumnData::F64(closed))
        .with_unit("field_max", ColumnData::F64(koe.clone()), "kOe");
    let mut figure = figure("field of maximum torque", "θ (deg)", "H_max (kOe)");
    figure.log_y = true;
    figure.series.push(line(material.name.clone(), theta, koe));
    (table, figure)
}

/// Long-format rows (angle, field, h, value) of a family of curves.
#[derive(Default)]
struct Rows {
    theta: Vec<f64>,
    field: Vec<f64>,
    h: Vec<f64>,
    value: Vec<f64>,
}

impl Rows {
    fn push(&mut self, theta_deg: f64, field: f64, h: f64, value: f64) {
        self.theta.push(theta_deg);
        self.field.push(to_unit(field, "kOe"));
        self.h.push(h);
        self.value.push(value);
    }

    fn add(&mut self, theta_deg: &[f64], field: f64, h: f64, values: &[f64]) {
        for (t, v) in theta_deg.iter().zip(values) {
            self.push(*t, field, h, *v);
        }
    }

    fn table(self, value_name: &str) -> Table {
        let unit = if value_name.ends_with("_deg") {
            "deg"
        } else {
            "1"
        };
        Table::new()
            .with_unit("theta", ColumnData::F64(self.theta), "deg")
            .with_unit("field", ColumnData::F64(self.field), "kOe")
            .with("h", ColumnData::F64(self.h))
            .with_unit(value_name, ColumnData::F64(self.value), unit)
    }
}

fn figure(title: &str, x: &str, y: &str) -> Figure {
    Figure {
        title: title.into(),
        x_label: x.into(),
        y_label: y.into(),
        ..Figure::default()
    }
}

fn line(label: String, x: Vec<f64>, y: Vec<f64>) -> Series {
    Series {
        label,
        x,
        y,
        y_err: None,
        style: SeriesStyle::Line,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::materials::MaterialDb;

    #[test]
    fn numerical_field_of_maximum_torque_is_the_closed_form() {
        for deg in [46.0f64, 50.0, 60.0, 75.0, 89.5] {
            let h = field_of_maximum_torque(deg.to_radians());
            let closed = 0.5 / (deg - 45.0).to_radians().sin();
            assert!((h / closed - 1.0).abs() < 1e-6, "θ={deg}: {h} vs {closed}");
        }
    }

    #[test]
    fn tables_have_one_row_per_point() {
        let m = MaterialDb::builtin().get("srfe12o19").unwrap().clone();
        let (t, f) = psi_vs_theta(&m, &default_fields(&m));
        assert_eq!(t.n_rows(), 5 * CURVE_POINTS);
        assert_eq!(f.series.len(), 5);
        let (t, _) = torque_vs_field(&m);
        assert_eq!(t.n_rows(), TORQUE_ANGLES_DEG.len() * CURVE_POINTS);
        let (t, _) = maximum_torque_field(&m);
        assert_eq!(t.n_rows(), 88);
    }
}

//! What a run leaves behind: a CSV table (one row per 1 ms cycle) and a PNG
//! plot (pose error and tensions), drawn with the host tools' plots
//! (`cdpr-plot`, DejaVu Sans embedded), and the figures the tests check.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use cdpr_control::protocol::State;
use cdpr_control::CABLES;
use cdpr_plot::{draw_line_plot, render_png, LinePlot, Series, PALETTE};

use crate::scenario::{Outcome, Row};

/// The CSV table: `time,state,reason,brakes,locked,x,y,z,rx,ry,rz,ex,ey,ez,
/// erx,ery,erz,position_error_mm,rotation_error_deg,speed,t1..t8,
/// cmd_t1..cmd_t8,tau1..tau8,fb_fx,fb_fy,fb_fz,fb_mx,fb_my,fb_mz,
/// est_x..est_rz,est_error_mm,residual_mm,unreadable_drive` (pose in the
/// conventions' order, errors `reference - pose` in the base frame,
/// tensions the true ones, `cmd_` the controller's, empty where it had
/// none; `fb_` the PID's wrench; `est_` the loop's pose estimate, its
/// position error against the true pose and the estimator's worst cable
/// residual, empty where there was no estimate; the drive the loop could
/// not read, empty if none).
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from(
        "time,state,reason,brakes,locked,x,y,z,rx,ry,rz,ex,ey,ez,erx,ery,erz,position_error_mm,rotation_error_deg,speed",
    );
    for prefix in ["t", "cmd_t", "tau"] {
        for i in 1..=CABLES {
            let _ = write!(s, ",{prefix}{i}");
        }
    }
    s.push_str(",fb_fx,fb_fy,fb_fz,fb_mx,fb_my,fb_mz,est_x,est_y,est_z,est_rx,est_ry,est_rz,est_error_mm,residual_mm,unreadable_drive\n");
    for r in rows {
        let _ = write!(
            s,
            "{:.3},{},{},{},{}",
            r.t,
            r.state.name(),
            r.reason.name(),
            u8::from(r.brakes),
            u8::from(r.locked)
        );
        for v in r.pose.iter().chain(&r.error) {
            let _ = write!(s, ",{v:.7}");
        }
        let _ = write!(
            s,
            ",{:.4},{:.5},{:.5}",
            r.position_error() * 1e3,
            r.rotation_error().to_degrees(),
            r.speed
        );
        for v in &r.tensions {
            let _ = write!(s, ",{v:.3}");
        }
        for v in &r.commanded {
            if v.is_finite() {
                let _ = write!(s, ",{v:.3}");
            } else {
                s.push(',');
            }
        }
        for v in &r.torques {
            let _ = write!(s, ",{v:.5}");
        }
        for v in &r.feedback {
            let _ = write!(s, ",{v:.4}");
        }
        for v in &r.estimate {
            if v.is_finite() {
                let _ = write!(s, ",{v:.7}");
            } else {
                s.push(',');
            }
        }
        let e = r.estimate_error();
        let e = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        for v in [e * 1e3, f64::from(r.residual) * 1e3] {
            if v.is_finite() {
                let _ = write!(s, ",{v:.4}");
            } else {
                s.push(',');
            }
        }
        match r.unreadable_drive {
            Some(d) => {
                let _ = write!(s, ",{d}");
            }
            None => s.push(','),
        }
        s.push('\n');
    }
    s
}

/// Intervals (s) where the state is not Enabled, for shading.
fn not_enabled(rows: &[Row]) -> Vec<(f64, f64)> {
    let mut bands = Vec::new();
    let mut start = None;
    for r in rows {
        match (r.state == State::Enabled, start) {
            (false, None) => start = Some(r.t),
            (true, Some(a)) => {
                bands.push((a, r.t));
                start = None;
            }
            _ => {}
        }
    }
    if let (Some(a), Some(last)) = (start, rows.last()) {
        bands.push((a, last.t));
    }
    bands
}

/// The four panels: position error (mm, per axis), rotation error (deg,
/// per axis), the true tensions (N) with the limits, and the estimate's
/// position error against the true pose (mm, per axis) with the
/// estimator's residual; grey-red bands where the state is not Enabled.
pub fn plots(outcome: &Outcome) -> [LinePlot; 4] {
    // The robot file's (uniform) tension limits, drawn as lines.
    let limits: Vec<(f64, &str)> = crate::scenario::load_robot(&outcome.scenario.robot)
        .map(|r| vec![(r.limits().min()[0], "t_min"), (r.limits().max()[0], "t_max")])
        .unwrap_or_default();
    let rows = &outcome.rows;
    let bands = not_enabled(rows);
    let band_label = "not enabled".to_string();
    let axis = |k: usize, scale: f64, name: &str| {
        Series::from_samples(name, PALETTE[k % 3], rows.iter().map(|r| (r.t, Some(r.error[k] * scale))))
    };
    let title = &outcome.scenario.name;
    let position = LinePlot {
        title: format!("{title}: position error (reference - pose)"),
        x_label: "time [s]".into(),
        y_label: "error [mm]".into(),
        series: vec![axis(0, 1e3, "x"), axis(1, 1e3, "y"), axis(2, 1e3, "z")],
        bands: bands.clone(),
        band_label: band_label.clone(),
        include_zero: true,
        ..LinePlot::default()
    };
    let rotation = LinePlot {
        title: format!("{title}: rotation error (rotation vector)"),
        x_label: "time [s]".into(),
        y_label: "error [deg]".into(),
        series: vec![
            axis(3, 180.0 / core::f64::consts::PI, "about x"),
            axis(4, 180.0 / core::f64::consts::PI, "about y"),
            axis(5, 180.0 / core::f64::consts::PI, "about z"),
        ],
        bands: bands.clone(),
        band_label: band_label.clone(),
        include_zero: true,
        ..LinePlot::default()
    };
    let tensions = LinePlot {
        title: format!("{title}: cable tensions (simulated)"),
        x_label: "time [s]".into(),
        y_label: "tension [N]".into(),
        series: (0..CABLES)
            .map(|i| {
                Series::from_samples(
                    format!("cable {}", i + 1),
                    PALETTE[i],
                    rows.iter().map(|r| (r.t, Some(r.tensions[i]))),
                )
            })
            .collect(),
        hlines: limits.iter().map(|&(t, name)| (t, name.into())).collect(),
        bands: bands.clone(),
        band_label: band_label.clone(),
        include_zero: true,
    };
    let finite = |v: f64| v.is_finite().then_some(v);
    let mut series: Vec<Series> = (0..3)
        .map(|k| {
            Series::from_samples(
                ["x", "y", "z"][k],
                PALETTE[k % 3],
                rows.iter().map(|r| (r.t, finite(r.estimate_error()[k] * 1e3))),
            )
        })
        .collect();
    series.push(Series::from_samples(
        "residual",
        PALETTE[3],
        rows.iter().map(|r| (r.t, finite(f64::from(r.residual) * 1e3))),
    ));
    let estimate = LinePlot {
        title: format!("{title}: estimated - true position, and the estimator's residual"),
        x_label: "time [s]".into(),
        y_label: "[mm]".into(),
        series,
        bands,
        band_label,
        include_zero: true,
        ..LinePlot::default()
    };
    [position, rotation, tensions, estimate]
}

/// Writes `DIR/NAME.csv` and `DIR/NAME.png`; returns their paths.
pub fn write(outcome: &Outcome, dir: &Path) -> Result<(PathBuf, PathBuf), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let name = &outcome.scenario.name;
    let csv_path = dir.join(format!("{name}.csv"));
    std::fs::write(&csv_path, csv(&outcome.rows)).map_err(|e| format!("{}: {e}", csv_path.display()))?;
    let panels = plots(outcome);
    let png = render_png((1100, 1600), |root| {
        for (area, plot) in root.split_evenly((4, 1)).into_iter().zip(&panels) {
            draw_line_plot(area, plot)?;
        }
        Ok(())
    })
    .map_err(|e| e.to_string())?;
    let png_path = dir.join(format!("{name}.png"));
    std::fs::write(&png_path, png).map_err(|e| format!("{}: {e}", png_path.display()))?;
    Ok((csv_path, png_path))
}

/// Figures of a run.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Figures {
    /// Largest `|position error|` from Enable (plus `settle`) to the event
    /// (or the end), m.
    pub position_error: f64,
    /// Largest rotation error over the same window, rad.
    pub rotation_error: f64,
    /// Smallest true tension over the same window, N.
    pub tension_min: f64,
    /// Largest true tension over the same window, N.
    pub tension_max: f64,
    /// Smallest and largest commanded tension over the same window, N.
    pub commanded: (f32, f32),
    /// Largest distance of the estimated position from the true one over
    /// the same window, m (cycles with an estimate).
    pub estimate_error: f64,
    /// Largest estimator residual over the same window, m.
    pub residual: f64,
    /// From the event on: largest distance of the platform origin from
    /// where it was at the event, m.
    pub displacement: f64,
    /// From the event on: largest drop of the origin below its height at the event, m.
    pub drop: f64,
    /// From the event on: largest speed of the origin, m/s.
    pub speed: f64,
    /// From the brakes locking on: largest speed, m/s.
    pub speed_locked: f64,
    /// First time the state was Fault, s.
    pub fault_at: Option<f64>,
    /// First time the brakes held after the fault, s.
    pub locked_at: Option<f64>,
}

/// The figures of `outcome`; the tracking window starts `settle` s after
/// the Enable.
pub fn figures(outcome: &Outcome, settle: f64) -> Figures {
    let s = &outcome.scenario;
    let from = s.enable_at + settle;
    let to = s.event.unwrap_or(f64::INFINITY);
    let mut f = Figures {
        tension_min: f64::INFINITY,
        tension_max: f64::NEG_INFINITY,
        commanded: (f32::INFINITY, f32::NEG_INFINITY),
        ..Figures::default()
    };
    for r in outcome.rows.iter().filter(|r| r.t >= from && r.t < to) {
        f.position_error = f.position_error.max(r.position_error());
        f.rotation_error = f.rotation_error.max(r.rotation_error());
        for &t in &r.tensions {
            f.tension_min = f.tension_min.min(t);
            f.tension_max = f.tension_max.max(t);
        }
        for &t in r.commanded.iter().filter(|t| t.is_finite()) {
            f.commanded = (f.commanded.0.min(t), f.commanded.1.max(t));
        }
        let e = r.estimate_error();
        let e = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]).sqrt();
        if e.is_finite() {
            f.estimate_error = f.estimate_error.max(e);
        }
        if r.residual.is_finite() {
            f.residual = f.residual.max(f64::from(r.residual));
        }
    }
    f.fault_at = outcome.rows.iter().find(|r| r.state == State::Fault).map(|r| r.t);
    if let Some(fault) = f.fault_at {
        f.locked_at = outcome.rows.iter().find(|r| r.t >= fault && r.locked).map(|r| r.t);
    }
    if let Some(event) = s.event {
        if let Some(at) = outcome.rows.iter().find(|r| r.t >= event) {
            for r in outcome.rows.iter().filter(|r| r.t >= event) {
                let d = ((r.pose[0] - at.pose[0]).powi(2)
                    + (r.pose[1] - at.pose[1]).powi(2)
                    + (r.pose[2] - at.pose[2]).powi(2))
                .sqrt();
                f.displacement = f.displacement.max(d);
                f.drop = f.drop.max(at.pose[2] - r.pose[2]);
                f.speed = f.speed.max(r.speed);
                if f.locked_at.is_some_and(|l| r.t >= l) {
                    f.speed_locked = f.speed_locked.max(r.speed);
                }
            }
        }
    }
    f
}

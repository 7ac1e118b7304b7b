//! Pictures a person can check: the hysteresis loop (like Fig. 8.2) and the arm with a
//! cylinder in two orthographic views beside both camera images.

use plotters::prelude::*;
use std::path::Path;

use crate::plot::{fonts, side_legend, with_legend, Mark};

use trn_plant::joint::Joint;
use trn_plant::kinematics::{forward, lights};
use trn_plant::{Plant, SimConfig};

type R = Result<(), Box<dyn std::error::Error>>;

/// Joint `j`'s pressure-angle loop: pressure increased from -1 to 1, then decreased.
pub fn hysteresis(cfg: &SimConfig, joint: usize, path: &Path) -> R {
    let jc = &cfg.joints[joint];
    let mut j = Joint::new(jc);
    j.settle_at(-1.0);
    let n = 200;
    let up: Vec<(f64, f64)> = (0..=n)
        .map(|i| {
            let p = -1.0 + 2.0 * i as f64 / n as f64;
            j.settle_at(p);
            (p, j.angle_deg())
        })
        .collect();
    let down: Vec<(f64, f64)> = (0..=n)
        .map(|i| {
            let p = 1.0 - 2.0 * i as f64 / n as f64;
            j.settle_at(p);
            (p, j.angle_deg())
        })
        .collect();
    fonts();
    let root = BitMapBackend::new(path, (1100, 650)).into_drawing_area();
    root.fill(&WHITE)?;
    let (area, side) = with_legend(&root);
    let mut chart = ChartBuilder::on(&area)
        .caption(
            format!(
                "Joint {} ({}): pressure difference vs angle (cf. Fig. 8.2)",
                joint + 1,
                jc.name
            ),
            ("sans-serif", 22),
        )
        .margin(15)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(-1.05f64..1.05, (jc.min_deg - 2.0)..(jc.max_deg + 2.0))?;
    chart
        .configure_mesh()
        .x_desc("pressure difference (normalised)")
        .y_desc("joint angle (deg)")
        .draw()?;
    chart.draw_series(LineSeries::new(up, RED.stroke_width(2)))?;
    chart.draw_series(LineSeries::new(down, BLUE.stroke_width(2)))?;
    side_legend(
        &side,
        &[
            ("pressure increasing".into(), RED, Mark::Line),
            ("pressure decreasing".into(), BLUE, Mark::Line),
        ],
    )?;
    root.present()?;
    Ok(())
}

/// The arm at its current pose with a cylinder placed for it: side and top views, and what
/// both cameras see.
pub fn arm(plant: &mut Plant, path: &Path) -> R {
    let cfg = plant.config().clone();
    let chain = forward(&cfg, &plant.joint_angles());
    let cyl = plant.place_cylinder();
    let l = lights(&cfg, &chain.pose);
    let links = chain.links();
    let half = cyl.axis * (cyl.length / 2.0);
    let cyl_ends = [cyl.centre + half, cyl.centre - half];
    fonts();
    let root = BitMapBackend::new(path, (1400 + crate::plot::LEGEND_W, 1000)).into_drawing_area();
    root.fill(&WHITE)?;
    let (main, side) = with_legend(&root);
    side_legend(
        &side,
        &[
            ("arm: base, shoulder,".into(), BLACK, Mark::Line),
            ("elbow, wrist, gripper".into(), WHITE, Mark::Dot),
            ("lights p, q".into(), RED, Mark::Dot),
            ("cylinder".into(), GREEN, Mark::Line),
            ("cylinder centre".into(), BLUE, Mark::Dot),
        ],
    )?;
    let (top, bottom) = main.split_vertically(500);
    let (side, plan) = top.split_horizontally(700);
    let (cam0, cam1) = bottom.split_horizontally(700);
    for (area, (a, b), name) in [
        (&side, (0usize, 2usize), "side view (x forward, z up), mm"),
        (&plan, (0, 1), "top view (x forward, y left), mm"),
    ] {
        let mut ch = ChartBuilder::on(area)
            .caption(name, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(45)
            .build_cartesian_2d(-100f64..1200.0, -600f64..1200.0)?;
        ch.configure_mesh()
            .x_label_formatter(&|x: &f64| format!("{x:.0}"))
            .y_label_formatter(&|y: &f64| format!("{y:.0}"))
            .draw()?;
        ch.draw_series(LineSeries::new(
            links.iter().map(|p| (p[a], p[b])),
            BLACK.stroke_width(4),
        ))?;
        ch.draw_series(
            links
                .iter()
                .map(|p| Circle::new((p[a], p[b]), 4, BLACK.filled())),
        )?;
        ch.draw_series(LineSeries::new(
            cyl_ends.iter().map(|p| (p[a], p[b])),
            GREEN.stroke_width(12),
        ))?;
        ch.draw_series(l.iter().map(|p| Circle::new((p[a], p[b]), 5, RED.filled())))?;
        ch.draw_series(std::iter::once(Circle::new(
            (cyl.centre[a], cyl.centre[b]),
            5,
            BLUE.filled(),
        )))?;
    }
    let obs = plant.observe_gripper_lights_true();
    let centre = plant.observe_cylinder_centre_true();
    for (cam, area) in [(0usize, &cam0), (1, &cam1)] {
        let (w, h) = (
            cfg.cameras[cam].resolution[0] as f64,
            cfg.cameras[cam].resolution[1] as f64,
        );
        let mut ch = ChartBuilder::on(area)
            .caption(format!("camera {cam} image (pixels)"), ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(30)
            .y_label_area_size(45)
            .build_cartesian_2d(0f64..w, h..0f64)?;
        ch.configure_mesh()
            .x_label_formatter(&|x: &f64| format!("{x:.0}"))
            .y_label_formatter(&|y: &f64| format!("{y:.0}"))
            .draw()?;
        for i in 0..2 {
            let p = obs.points[2 * i + cam];
            if p.status == trn_plant::PointStatus::Valid {
                ch.draw_series(std::iter::once(Circle::new((p.x, p.y), 6, RED.filled())))?;
            }
        }
        let c = centre.points[cam];
        if c.status == trn_plant::PointStatus::Valid {
            ch.draw_series(std::iter::once(Circle::new((c.x, c.y), 6, BLUE.filled())))?;
        }
    }
    root.present()?;
    Ok(())
}

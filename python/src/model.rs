//! The arm's robot description (URDF, MJCF) and the plant's own forward kinematics, for
//! tools outside the project: `trn_plant::model` writes the description, and a user (or
//! python/tests/test_model.py) checks it against [`arm_frames`].

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use trn_plant::kinematics::{forward, lights};
use trn_plant::model;

use crate::arm::resolve;

/// The arm of a named plant (or a TOML file) as `"urdf"` or `"mjcf"` text.
#[pyfunction]
#[pyo3(signature = (config = "realistic", format = "urdf"))]
pub fn arm_model(config: &str, format: &str) -> PyResult<String> {
    let cfg = resolve(config)?;
    match format {
        "urdf" => Ok(model::urdf(&cfg)),
        "mjcf" => Ok(model::mjcf(&cfg)),
        other => Err(PyValueError::new_err(format!(
            "format is \"urdf\" or \"mjcf\", not {other:?}"
        ))),
    }
}

/// The plant's forward kinematics at the five joint angles `q` (radians: base, shoulder,
/// elbow, wrist A, wrist B): each frame's origin in the base frame (mm) by the description's
/// names (`upper_arm` at the shoulder, `forearm` at the elbow, `wrist`, `gripper_centre`,
/// `light_p`, `light_q`), and the gripper's axes (`approach`, `finger_axis`, `normal`).
#[pyfunction]
#[pyo3(signature = (q, config = "realistic"))]
pub fn arm_frames<'py>(py: Python<'py>, q: Vec<f64>, config: &str) -> PyResult<Bound<'py, PyDict>> {
    let q: [f64; 5] = q
        .try_into()
        .map_err(|q: Vec<f64>| PyValueError::new_err(format!("q has 5 angles, not {}", q.len())))?;
    if q.iter().any(|a| !a.is_finite()) {
        return Err(PyValueError::new_err("q must be finite"));
    }
    let cfg = resolve(config)?;
    let c = forward(&cfg, &q);
    let [p, l_q] = lights(&cfg, &c.pose);
    let d = PyDict::new(py);
    // each point a list [x, y, z]
    let xyz = <[f64; 3]>::from;
    d.set_item("upper_arm", xyz(c.shoulder))?;
    d.set_item("forearm", xyz(c.elbow))?;
    d.set_item("wrist", xyz(c.wrist))?;
    d.set_item("gripper_centre", xyz(c.pose.centre_mm))?;
    d.set_item("light_p", xyz(p))?;
    d.set_item("light_q", xyz(l_q))?;
    d.set_item("approach", xyz(c.pose.approach))?;
    d.set_item("finger_axis", xyz(c.pose.finger_axis))?;
    d.set_item("normal", xyz(c.pose.normal))?;
    Ok(d)
}

//! The camera and the swarm's rotation (`camera`, `plane`): the paper's
//! CameraX/Y/Z and PlaneRX/RY/RZ sweeps, the field of view, and the absolute
//! or ground-observer camera that replaces the relative one.

use serde::{Deserialize, Serialize};

use super::formation::AbsoluteCamera;
use super::observer;
use super::sweep::SweepRange;

/// CameraX/Y/Z sweeps (relative units, see docs/conventions.md) and the lens.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct CameraSweep {
    /// CameraX: sideways offset in units of the swarm radius R.
    pub x: SweepRange,
    /// CameraY: vertical offset in units of R.
    pub y: SweepRange,
    /// CameraZ: distance in units of the distance that just fits the swarm in view.
    pub z: SweepRange,
    /// Vertical field of view.
    pub fov_y_deg: f64,
    /// An absolute pose in metres; when set, CameraX/Y/Z are not used.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub absolute: Option<AbsoluteCamera>,
    /// A ground observer's camera looking up at the swarm (docs/realism.md); when set, CameraX/Y/Z are not used.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub observer: Option<observer::ObserverCamera>,
}

impl Default for CameraSweep {
    fn default() -> Self {
        Self {
            x: SweepRange::fixed(0.0),
            y: SweepRange::fixed(0.0),
            z: SweepRange::fixed(1.0),
            fov_y_deg: 50.0,
            absolute: None,
            observer: None,
        }
    }
}

/// PlaneRX/RY/RZ: rotation of the whole swarm about the volume's centre, degrees.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PlaneSweep {
    pub rx: SweepRange,
    pub ry: SweepRange,
    pub rz: SweepRange,
}

//! Formations and sequences (issue 12), without a GPU: separation, the ring's
//! projection, determinism, the paper's equations 4–5 along a sequence, track
//! and split stability, the absolute camera.

use glam::{DVec2, DVec3};
use swarmshot::preset::sweep::SweepRange;
use swarmshot::preset::{
    AbsoluteCamera, AttitudeRanges, Formation, FormationShape, Motion, Placement, Preset,
    SequenceCamera, SequenceSpec,
};
use swarmshot::scene::math::slerp;
use swarmshot::scene::{FrameScene, build_frame};

fn formation_preset(shape: FormationShape, count: u32) -> Preset {
    let mut p = Preset {
        seed: 11,
        placement: Placement::Formation(Formation {
            shape,
            count,
            spacing: 3.0,
            heading_deg: (-180.0, 180.0),
            // The most jitter validation allows for spacing 3 and separation 1
            // (wedges at 35° are narrower: 2·sin 35° = 1.15 spans across).
            position_jitter: 0.0,
            attitude_jitter: AttitudeRanges::default(),
            min_separation: 1.0,
        }),
        ..Preset::default()
    };
    p.repeats = 20;
    let max_jitter = {
        let Placement::Formation(f) = &p.placement else {
            unreachable!()
        };
        f.nominal_min_spacing()
            .map_or(0.5, |d| (d - 1.0) / (2.0 * 3f64.sqrt()))
    };
    if let Placement::Formation(f) = &mut p.placement {
        f.position_jitter = max_jitter * 0.999;
    }
    p
}

fn min_distance(scene: &FrameScene) -> f64 {
    let mut best = f64::INFINITY;
    for (i, a) in scene.drones.iter().enumerate() {
        for b in &scene.drones[i + 1..] {
            best = best.min(a.position.distance(b.position));
        }
    }
    best
}

#[test]
fn every_formation_keeps_the_minimum_separation() {
    for shape in FormationShape::all() {
        for count in [2, 7, 40] {
            let shape = match shape {
                FormationShape::Clustered { cluster_gap, .. } => FormationShape::Clustered {
                    clusters: 3.min(count),
                    cluster_gap,
                },
                _ => shape.clone(),
            };
            let p = formation_preset(shape.clone(), count);
            p.validate()
                .unwrap_or_else(|e| panic!("{shape:?} ×{count} should be valid: {e:?}"));
            let span = p.max_model_size_m();
            for index in 0..p.frame_count() {
                let scene = build_frame(&p, index).expect("frame");
                assert_eq!(
                    scene.drones.len() as u32 + scene.placement_shortfall,
                    count,
                    "{shape:?}"
                );
                if scene.drones.len() >= 2 {
                    let d = min_distance(&scene);
                    assert!(
                        d >= span * 1.0 - 1e-9,
                        "{shape:?} ×{count}, frame {index}: two drones {d} m apart, separation {span} m"
                    );
                }
            }
        }
    }
}

#[test]
fn unjittered_shapes_are_exactly_at_their_nominal_spacing() {
    for shape in FormationShape::all() {
        let mut p = formation_preset(shape.clone(), 12);
        let Placement::Formation(f) = &mut p.placement else {
            unreachable!()
        };
        f.position_jitter = 0.0;
        let Some(nominal) = f.nominal_min_spacing() else {
            continue;
        };
        let scene = build_frame(&p, 3).expect("frame");
        let d = min_distance(&scene);
        let want = nominal * p.max_model_size_m();
        assert!((d - want).abs() < 1e-9, "{shape:?}: {d} m, want {want} m");
    }
}

#[test]
fn validation_refuses_jitter_that_breaks_the_separation() {
    let mut p = formation_preset(FormationShape::LineAbreast, 5);
    if let Placement::Formation(f) = &mut p.placement {
        f.position_jitter = 0.6; // 3 − 2·√3·0.6 = 0.92 < 1
    }
    let errors = p.validate().expect_err("must be refused");
    assert!(
        errors.iter().any(|e| e.field == "placement.min_separation"),
        "{errors:?}"
    );
    let mut p = formation_preset(
        FormationShape::Wedge {
            half_angle_deg: 10.0,
        },
        5,
    );
    if let Placement::Formation(f) = &mut p.placement {
        f.position_jitter = 0.0; // 2·sin 10° · 3 = 1.04 ≥ 1: fine
    }
    assert!(p.validate().is_ok());
    if let Placement::Formation(f) = &mut p.placement {
        f.spacing = 2.5; // 2·sin 10° · 2.5 = 0.87 < 1
    }
    assert!(p.validate().is_err());
}

#[test]
fn formations_are_deterministic_in_the_frame_seed() {
    for shape in FormationShape::all() {
        let p = formation_preset(shape.clone(), 9);
        let a = build_frame(&p, 5).expect("frame");
        let b = build_frame(&p, 5).expect("frame");
        assert_eq!(a, b, "{shape:?}");
        let c = build_frame(&p, 6).expect("frame");
        assert_ne!(
            a.drones, c.drones,
            "{shape:?}: frames 5 and 6 drew the same"
        );
    }
}

/// Solve the 5×5 system `m·x = b` by Gaussian elimination with partial pivoting.
fn solve5(m: [[f64; 5]; 5], b: [f64; 5]) -> [f64; 5] {
    // The augmented matrix [m | b].
    let mut a: [[f64; 6]; 5] =
        std::array::from_fn(|r| std::array::from_fn(|c| if c < 5 { m[r][c] } else { b[r] }));
    for col in 0..5 {
        let pivot = (col..5)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .expect("rows");
        a.swap(col, pivot);
        let top = a[col];
        for row in a.iter_mut().skip(col + 1) {
            let f = row[col] / top[col];
            for (x, t) in row.iter_mut().zip(top.iter()) {
                *x -= f * t;
            }
        }
    }
    let mut x = [0.0; 5];
    for row in (0..5).rev() {
        let s: f64 = (row + 1..5).map(|k| a[row][k] * x[k]).sum();
        x[row] = (a[row][5] - s) / a[row][row];
    }
    x
}

#[test]
fn a_ring_viewed_along_its_axis_projects_onto_an_ellipse() {
    // Tilted 90°, the ring's axis is world +Z, the camera's line of sight;
    // CameraY moves the camera a little off the axis, so the circle is an
    // ellipse (not a circle) in the image.
    let mut p = formation_preset(FormationShape::Ring { tilt_deg: 90.0 }, 12);
    if let Placement::Formation(f) = &mut p.placement {
        f.position_jitter = 0.0;
        f.heading_deg = (0.0, 0.0);
    }
    p.repeats = 1;
    for camera_y in [0.0, 0.4] {
        p.camera.y = SweepRange::fixed(camera_y);
        let scene = build_frame(&p, 0).expect("frame");
        let cam = &scene.camera;
        let pts: Vec<DVec2> = scene
            .drones
            .iter()
            .map(|d| {
                cam.project_camera_point(cam.camera_from_world_point(d.position))
                    .expect("in front")
            })
            .collect();
        assert_eq!(pts.len(), 12);
        let mean = pts.iter().sum::<DVec2>() / pts.len() as f64;
        let scale = pts.iter().map(|p| (*p - mean).length()).fold(0.0, f64::max);
        let q: Vec<DVec2> = pts.iter().map(|p| (*p - mean) / scale).collect();
        // A x² + B xy + C y² + D x + E y = 1 through five of the points.
        let row = |p: DVec2| [p.x * p.x, p.x * p.y, p.y * p.y, p.x, p.y];
        let m = [row(q[0]), row(q[2]), row(q[4]), row(q[7]), row(q[9])];
        let [a, b, c, d, e] = solve5(m, [1.0; 5]);
        assert!(
            b * b - 4.0 * a * c < 0.0,
            "the conic through the centres is not an ellipse"
        );
        for (i, p) in q.iter().enumerate() {
            let r = a * p.x * p.x + b * p.x * p.y + c * p.y * p.y + d * p.x + e * p.y - 1.0;
            assert!(
                r.abs() < 1e-8,
                "centre {i} is {r} off the ellipse (CameraY {camera_y})"
            );
        }
        if camera_y > 0.0 {
            // Off the axis the ellipse is not a circle.
            assert!((a - c).abs() > 1e-3 || b.abs() > 1e-3);
        }
    }
}

fn sequence_preset(camera: SequenceCamera) -> Preset {
    let mut p = formation_preset(
        FormationShape::Wedge {
            half_angle_deg: 35.0,
        },
        7,
    );
    p.repeats = 3;
    p.plane.ry = SweepRange::new(0.0, 30.0, 30.0);
    p.sequence = Some(SequenceSpec {
        steps: 6,
        motion: Motion {
            translate_m: (2.0, 1.0, 8.0),
            turn_deg: 50.0,
            bank_deg: 25.0,
            displacement_m: (0.3, 0.2, 0.3),
            attitude_change: AttitudeRanges {
                roll_deg: (-20.0, 20.0),
                pitch_deg: (-10.0, 10.0),
                yaw_deg: (-170.0, 170.0),
            },
        },
        camera,
        frame_rate: 25,
    });
    p
}

#[test]
fn sequence_frames_follow_equations_4_and_5_with_stable_tracks() {
    let p = sequence_preset(SequenceCamera::Fixed);
    p.validate().expect("valid");
    let len = 7u64;
    assert_eq!(p.frame_count(), 2 * 3 * len);
    for seq in 0..p.frame_count() / len {
        let frames: Vec<FrameScene> = (seq * len..(seq + 1) * len)
            .map(|i| build_frame(&p, i).expect("frame"))
            .collect();
        let (first, last) = (&frames[0], &frames[len as usize - 1]);
        for (t, f) in frames.iter().enumerate() {
            let s = f.sequence.expect("sequence frame");
            assert_eq!((s.id, s.step, s.steps), (seq, t as u64, len - 1));
            assert_eq!(f.split, first.split, "a sequence stays in one split");
            assert_eq!(f.sky, first.sky, "one sky per sequence");
            assert_eq!(f.camera, first.camera, "a fixed camera stays put");
            assert_eq!(f.drones.len(), first.drones.len(), "tracks stay");
            let alpha = t as f64 / (len - 1) as f64;
            for (i, d) in f.drones.iter().enumerate() {
                let (a, b) = (&first.drones[i], &last.drones[i]);
                assert_eq!(d.model, a.model, "track {} changed model", i + 1);
                let p = a.position + alpha * (b.position - a.position);
                assert!(
                    d.position.distance(p) < 1e-9,
                    "eq. 4, track {}, t {t}",
                    i + 1
                );
                let q = slerp(a.rotation, b.rotation, alpha);
                assert!(
                    d.rotation.angle_between(q) < 1e-6,
                    "eq. 5, track {}, t {t}",
                    i + 1
                );
            }
        }
        // The swarm moves: the last frame is not the first.
        assert!(first.drones[0].position.distance(last.drones[0].position) > 1.0);
    }
    // Sequences drawn apart differ.
    let a = build_frame(&p, 0).expect("frame");
    let b = build_frame(&p, len).expect("frame");
    assert_ne!(a.drones, b.drones);
}

#[test]
fn a_following_camera_keeps_its_offset_from_the_swarm() {
    let p = sequence_preset(SequenceCamera::Follow);
    let centroid =
        |f: &FrameScene| f.drones.iter().map(|d| d.position).sum::<DVec3>() / f.drones.len() as f64;
    let first = build_frame(&p, 0).expect("frame");
    let offset = first.camera.position - centroid(&first);
    for i in 1..7 {
        let f = build_frame(&p, i).expect("frame");
        let o = f.camera.position - centroid(&f);
        assert!(
            o.distance(offset) < 1e-9,
            "frame {i}: offset {o} ≠ {offset}"
        );
        assert_eq!(f.camera.camera_from_world, first.camera.camera_from_world);
    }
}

#[test]
fn an_absolute_camera_sits_where_the_preset_says() {
    let mut p = formation_preset(FormationShape::LineAbreast, 5);
    p.camera.absolute = Some(AbsoluteCamera {
        position_m: (0.0, 3.0, 40.0),
        look_at_m: (1.0, 0.0, 0.0),
    });
    p.validate().expect("valid");
    let scene = build_frame(&p, 0).expect("frame");
    assert_eq!(scene.camera.position, DVec3::new(0.0, 3.0, 40.0));
    let forward = scene.camera.camera_from_world.transpose() * DVec3::Z;
    let want = (DVec3::new(1.0, 0.0, 0.0) - scene.camera.position).normalize();
    assert!(forward.distance(want) < 1e-12);
    p.camera.absolute = Some(AbsoluteCamera {
        position_m: (1.0, 1.0, 1.0),
        look_at_m: (1.0, 1.0, 1.0),
    });
    let errors = p.validate().expect_err("camera on its target");
    assert!(
        errors
            .iter()
            .any(|e| e.field == "camera.absolute.look_at_m")
    );
}

#[test]
fn presets_without_sequences_keep_their_frames() {
    // The step radix is 1 and the split, sky and seed draws use the frame's own index.
    let mut p = Preset::default();
    p.repeats = 4;
    assert_eq!(p.sequence_len(), 1);
    assert_eq!(p.frame_radices().expect("radices")[8], 1);
    let scene = build_frame(&p, 3).expect("frame");
    assert!(scene.sequence.is_none());
    assert_eq!(scene.seed, swarmshot::seed::frame_seed(p.seed, 3));
}

#[test]
fn density_is_swept_with_the_volume_held_fixed() {
    let mut p = Preset::default();
    p.placement = Placement::Randomized {
        count: (1, 1),
        count_distribution: Default::default(),
        volume: swarmshot::preset::Volume::DensitySweep {
            size_m: (20.0, 10.0, 20.0),
            per_m3: SweepRange::new(0.001, 0.004, 0.001),
        },
        min_separation_m: 0.7,
    };
    p.repeats = 2;
    p.validate().expect("valid");
    assert_eq!(p.frame_count(), 4 * 2);
    let mut radii = Vec::new();
    for index in 0..p.frame_count() {
        let scene = build_frame(&p, index).expect("frame");
        let rho = scene.sweep.density_per_m3.expect("swept density");
        let want = 0.001 * (index / 2 + 1) as f64;
        assert!((rho - want).abs() < 1e-12, "frame {index}: ρ {rho}");
        let n = (rho * 4000.0).round() as usize;
        assert_eq!(scene.drones.len() + scene.placement_shortfall as usize, n);
        assert_eq!(scene.volume_half_extent_m, DVec3::new(10.0, 5.0, 10.0));
        radii.push(scene.volume_radius_m);
    }
    // The same volume, so the same camera distance, whatever the density.
    assert!(radii.windows(2).all(|w| w[0] == w[1]));
    let mut bad = p.clone();
    if let Placement::Randomized { volume, .. } = &mut bad.placement {
        *volume = swarmshot::preset::Volume::DensitySweep {
            size_m: (20.0, 10.0, 20.0),
            per_m3: SweepRange::new(0.0, 0.004, 0.001),
        };
    }
    let errors = bad.validate().expect_err("ρ = 0");
    assert!(errors.iter().any(|e| e.field == "placement.volume.per_m3"));
}

#[test]
fn the_formation_sequence_preset_loads_and_round_trips() {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("presets/formation_sequence.ron");
    let p = Preset::load(&path).expect("presets/formation_sequence.ron is valid");
    assert!(matches!(p.placement, Placement::Formation(_)));
    assert_eq!(p.sequence.as_ref().map(|s| s.steps), Some(24));
    assert_eq!(p.frame_count(), 100);
    let again = Preset::from_ron(&p.to_ron()).expect("its lock parses");
    assert_eq!(again, p);
    // A preset without the new fields writes none of them into its lock.
    let lock = Preset::default().to_ron();
    assert!(
        !lock.contains("sequence") && !lock.contains("absolute"),
        "{lock}"
    );
}

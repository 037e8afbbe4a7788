//! The thermal camera's cost per frame (src/sensor/thermal/), on the CPU
//! alone: a 1920×1080 background of presets/thermal.ron's kind (a sky
//! brightening downwards, grey clouds, scenery under a horizon at four
//! fifths of the height, the camera pitched up 5°) composed into the
//! radiance plane, then developed (blur, fixed pattern and noise, gain
//! control) to 8-bit RGBA and to 16-bit grey, and the capture chain
//! (`thermal.capture`) on the 8-bit frame, and the background's texture
//! (`thermal.texture` at its default, and as a Gaussian field) added to the plane, the detail
//! enhancement (`thermal.detail`) on it, a new window of
//! the field each run, and a backplate's plane (`plate_plane`) alone and with the optics'
//! blur on 15 drawn 12×12 px drones scattered over it (`blur_drawn`); the median wall time of 30
//! runs after 3 warm-ups and their mean CPU time (all threads, from /proc;
//! `support/timing.rs`). The drones' pixels (a few thousand) are left out.
//!
//! `cargo run --release --no-default-features --example thermal_bench`
//! (docs/realism.md, "Thermal camera"). `RAYON_NUM_THREADS` sets the threads.

#[path = "support/timing.rs"]
mod timing;

use glam::{Vec2, Vec3};
use swarmshot::preset::Preset;
use swarmshot::sensor::thermal::{self, Developed, Gain, Scratch, SkyTable, View};
use timing::median_ms;

fn main() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/presets/thermal.ron");
    let t = match Preset::open(std::path::Path::new(path)) {
        Ok(p) => p.thermal.unwrap_or_default(),
        Err(e) => {
            eprintln!("{e}");
            return;
        }
    };
    let (w, h) = (1920u32, 1080u32);
    let rgba: Vec<u8> = (0..w * h)
        .flat_map(|i| {
            let (x, y) = (i % w, i / w);
            let cloud = (x / 300 + y / 200) % 3 == 0;
            match () {
                _ if y > h * 4 / 5 => [70, 90 + (x % 7) as u8, 50, 255],
                _ if cloud => [200, 200, 205, 255],
                _ => [(90 + y / 12) as u8, (130 + y / 10) as u8, 230, 255],
            }
        })
        .collect();
    let pitch = 5f32.to_radians();
    let focal = 540.0 / 4f32.to_radians().tan();
    let view = View {
        width: w,
        height: h,
        up: Vec3::new(0.0, -pitch.cos(), pitch.sin()),
        focal_px: focal,
        principal: Vec2::new(960.0, 540.0),
    };
    let sky = SkyTable::new(&t);
    let pattern = thermal::fixed_pattern(&t, 4141, w, h);
    let mut scratch = Scratch::default();
    let mut out8 = vec![0u8; (w * h * 4) as usize];
    let mut out16 = vec![0u16; (w * h) as usize];
    let background = median_ms(|| thermal::sky_plane(&t, &sky, &view, &rgba, &mut scratch));
    let mut seed = 0;
    const AUTO: Gain = Gain::Automatic;
    let dev8 = median_ms(|| {
        thermal::sky_plane(&t, &sky, &view, &rgba, &mut scratch);
        seed += 1;
        let to = Developed::Rgba8(&mut out8);
        thermal::develop_into(&t, (w, h), (&pattern, seed), AUTO, &mut scratch, to);
    });
    let dev16 = median_ms(|| {
        thermal::sky_plane(&t, &sky, &view, &rgba, &mut scratch);
        seed += 1;
        let to = Developed::Grey16(&mut out16);
        thermal::develop_into(&t, (w, h), (&pattern, seed), AUTO, &mut scratch, to);
    });
    // The capture chain alone (`thermal.capture`, off in the preset) on the 8-bit frame:
    // an earlier compression and three border lines, as the fitted Anti-UAV presets have.
    let capture = swarmshot::preset::thermal::Capture {
        prior_dc_step: 16.0,
        prior_ac_step: 4.0,
        top_rows: vec![-52.0, -50.0],
        left_columns: vec![30.0],
        ..Default::default()
    };
    let chain = median_ms(|| thermal::capture::apply(&capture, (w, h), &mut out8));
    // The earlier compression over a low-rate codec's sparse noise, as the thermal fit
    // draws it (a fitted svanstrom-ir preset's noise, NETD 283 mK and a fixed pattern of
    // 412 mK, under an AC step of 9.7; src/fit/thermal/codec.rs): a fresh noisy frame each
    // run (copied in, the copy's own time taken off).
    let loud = swarmshot::preset::thermal::Thermal {
        netd_mk: 283.0,
        fixed_pattern_mk: 412.0,
        ..t.clone()
    };
    let loud_pattern = thermal::fixed_pattern(&loud, 4141, w, h);
    thermal::sky_plane(&loud, &sky, &view, &rgba, &mut scratch);
    let to = Developed::Rgba8(&mut out8);
    thermal::develop_into(&loud, (w, h), (&loud_pattern, 1), AUTO, &mut scratch, to);
    let fresh = out8.clone();
    let sparse = swarmshot::preset::thermal::Capture {
        prior_ac_step: 9.7,
        ..Default::default()
    };
    let copy = median_ms(|| out8.copy_from_slice(&fresh));
    let codec = median_ms(|| {
        out8.copy_from_slice(&fresh);
        thermal::capture::apply(&sparse, (w, h), &mut out8);
    });
    let codec = (codec.0 - copy.0, codec.1 - copy.1);
    // The detail enhancement (`thermal.detail`, off in the preset) on the developed scene's
    // plane at gain 2 and the default reach: a fresh copy of the plane each run (the copy's
    // own time taken off).
    thermal::sky_plane(&t, &sky, &view, &rgba, &mut scratch);
    let scene = scratch.plane.clone();
    let enhance = swarmshot::preset::thermal::Detail {
        gain: 2.0,
        ..Default::default()
    };
    let mut buffers = thermal::detail::Buffers::default();
    let copy = median_ms(|| scratch.plane.copy_from_slice(&scene));
    let detail = median_ms(|| {
        scratch.plane.copy_from_slice(&scene);
        thermal::detail::enhance(
            &enhance,
            &mut scratch.plane,
            (w as usize, h as usize),
            &mut buffers,
        );
    });
    let detail = (detail.0 - copy.0, detail.1 - copy.1);
    // The texture (`thermal.texture`, off in the preset) at its default (sharpness 3)
    // and as a Gaussian field (sharpness 0), a window 3 px further along the lattice
    // each run.
    let texture = swarmshot::preset::thermal::Texture::default();
    let gaussian = swarmshot::preset::thermal::Texture {
        sharpness: 0.0,
        ..texture
    };
    let per_k = thermal::radiance_per_kelvin(t.air_k);
    let mut along = 0.0;
    let mut field = |x: &swarmshot::preset::thermal::Texture| {
        median_ms(|| {
            along += 3.0;
            let anchor = thermal::texture::Anchor {
                seed: 7,
                origin: (along, -40.0),
            };
            thermal::texture::add(x, per_k, anchor, (w, h), &mut scratch.plane);
        })
    };
    let (gaussian, textured) = (field(&gaussian), field(&texture));
    // On the ground alone (`ground_only`): the background's ground share, then the field
    // times it.
    let mut share = Vec::new();
    let on_ground = median_ms(|| {
        along += 3.0;
        let anchor = thermal::texture::Anchor {
            seed: 7,
            origin: (along, -40.0),
        };
        thermal::ground_share(t.clear_saturation as f32, &view, &rgba, &mut share);
        thermal::texture::add_on(&texture, per_k, anchor, (w, h), &share, &mut scratch.plane);
    });
    let share_ms = median_ms(|| {
        thermal::ground_share(t.clear_saturation as f32, &view, &rgba, &mut share);
    });
    // A backplate: its plane alone (no blur: no plate kept), and with the blur on 15
    // drones drawn over it (the plate kept, the drawn box found and blurred).
    let sharp = swarmshot::preset::thermal::Thermal {
        blur_px: 0.0,
        ..t.clone()
    };
    let plate = median_ms(|| thermal::plate_plane(&sharp, (w, h), &rgba, &mut scratch));
    let drones = median_ms(|| {
        thermal::plate_plane(&t, (w, h), &rgba, &mut scratch);
        for k in 0..15usize {
            let (x0, y0) = (97 + k * 113, 61 + (k * 211) % 900);
            for y in y0..y0 + 12 {
                let row = y * w as usize;
                scratch.plane[row + x0..row + x0 + 12]
                    .iter_mut()
                    .for_each(|v| *v += 2.0);
            }
        }
        thermal::blur_drawn(t.blur_px as f32, (w, h), &mut scratch);
    });
    println!("threads {}", rayon::current_num_threads());
    println!("(median wall, mean CPU) ms a frame");
    println!(
        "background 1920x1080: {:.2}, {:.2}",
        background.0, background.1
    );
    println!(
        "background + develop to 8-bit RGBA: {:.2}, {:.2}",
        dev8.0, dev8.1
    );
    println!(
        "background + develop to 16-bit grey: {:.2}, {:.2}",
        dev16.0, dev16.1
    );
    println!(
        "capture chain on the 8-bit frame: {:.2}, {:.2}",
        chain.0, chain.1
    );
    println!(
        "earlier compression over sparse codec noise (AC step 9.7): {:.2}, {:.2}",
        codec.0, codec.1
    );
    println!(
        "detail enhancement (gain 2, reach 0.15): {:.2}, {:.2}",
        detail.0, detail.1
    );
    println!(
        "texture 1920x1080, Gaussian: {:.2}, {:.2}",
        gaussian.0, gaussian.1
    );
    println!("texture 1920x1080: {:.2}, {:.2}", textured.0, textured.1);
    println!(
        "texture 1920x1080 on the ground only: {:.2}, {:.2}",
        on_ground.0, on_ground.1
    );
    println!(
        "of which the ground share: {:.2}, {:.2}",
        share_ms.0, share_ms.1
    );
    println!("plate 1920x1080: {:.2}, {:.2}", plate.0, plate.1);
    println!(
        "plate + 15 drones + the blur on them: {:.2}, {:.2}",
        drones.0, drones.1
    );
}

//! The app's kittest harness, shared by tests/suite/gui.rs and tests/suite/gui_tools.rs
//! (included with `#[path]`; not a test target of its own).
#![allow(dead_code)]

use std::path::PathBuf;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use eframe::egui_wgpu;
use egui_kittest::Harness;
use swarmshot::app::{StartOptions, SwarmshotApp};

/// One harness at a time: each owns a lavapipe device and 2 cores are shared.
pub static GPU: Mutex<()> = Mutex::new(());

pub const WAIT: Duration = Duration::from_secs(300);

pub fn harness(preset: Option<PathBuf>) -> Harness<'static, SwarmshotApp> {
    harness_with(
        StartOptions {
            preset,
            restore_session: false,
        },
        None,
        [1400.0, 880.0],
    )
}

/// The app in a window of `size` points, started with `options` and, when given,
/// eframe's storage (a session saved by an earlier app: a restart).
pub fn harness_with(
    options: StartOptions,
    storage: Option<&'static dyn eframe::Storage>,
    size: [f32; 2],
) -> Harness<'static, SwarmshotApp> {
    let mut setup = egui_kittest::wgpu::default_wgpu_setup();
    if let egui_wgpu::WgpuSetup::CreateNew(create) = &mut setup {
        create.instance_descriptor.backends = wgpu::Backends::VULKAN;
    }
    Harness::builder()
        .with_size(size)
        .wgpu_setup(setup)
        .build_eframe(move |cc| {
            cc.storage = storage;
            SwarmshotApp::new(cc, options)
        })
}

/// eframe's storage in memory, for a restart within a test.
#[derive(Default)]
pub struct MemoryStorage(pub std::collections::HashMap<String, String>);

impl eframe::Storage for MemoryStorage {
    fn get_string(&self, key: &str) -> Option<String> {
        self.0.get(key).cloned()
    }
    fn set_string(&mut self, key: &str, value: String) {
        self.0.insert(key.to_owned(), value);
    }
    fn remove_string(&mut self, key: &str) {
        self.0.remove(key);
    }
    fn flush(&mut self) {}
}

/// Step the UI until `done` holds (the workers answer asynchronously).
pub fn wait_for(
    h: &mut Harness<'_, SwarmshotApp>,
    what: &str,
    done: impl Fn(&SwarmshotApp) -> bool,
) {
    let start = Instant::now();
    loop {
        h.step();
        if done(h.state()) {
            h.step();
            h.step();
            return;
        }
        assert!(
            start.elapsed() < WAIT,
            "timed out after {WAIT:?} waiting for {what}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

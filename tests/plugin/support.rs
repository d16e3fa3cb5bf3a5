//! What the plugin's tests share: a headless app (MinimalPlugins, or the renderer without a
//! window), whether a GPU adapter exists, the render app for pictures and reading them back.

pub(crate) use bevy::prelude::*;
pub(crate) use phonation::plugin::{FluidDiagnostics, FluidSimulation, FluidStatus, PhonationPlugin, SimulationControl};
pub(crate) use phonation::scene;

pub(crate) fn scene() -> scene::FluidScene {
    let text = std::fs::read_to_string(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/good_base.toml")).unwrap();
    scene::load(&text).unwrap()
}

/// Bevy's default plugins without the window loop (winit needs a display; these apps are
/// updated by hand).
pub(crate) fn headless_default_plugins(p: bevy::app::PluginGroupBuilder) -> bevy::app::PluginGroupBuilder {
    #[cfg(feature = "render")]
    let p = p.disable::<bevy::winit::WinitPlugin>();
    p
}

/// Whether a GPU adapter (lavapipe in CI) exists; without one a GPU test is skipped, except in
/// CI, where it must run.
pub(crate) fn has_gpu() -> bool {
    match phonation::gpu::GpuContext::new() {
        Ok(_) => true,
        Err(e) if std::env::var("CI").is_ok_and(|v| v == "true") => panic!("CI must run the GPU tests, but {e}"),
        Err(e) => {
            eprintln!("SKIPPED: no GPU adapter ({e})");
            false
        }
    }
}

/// A headless app with Bevy's renderer (no window, no camera) and the GPU plugin, ready to be
/// updated by hand; None (the test skipped) without an adapter outside CI.
pub(crate) fn render_world_app() -> Option<App> {
    use bevy::app::PluginsState;
    use bevy::window::{ExitCondition, WindowPlugin};
    if !has_gpu() {
        return None;
    }
    let mut app = App::new();
    app.add_plugins((
        headless_default_plugins(
            DefaultPlugins.set(WindowPlugin { primary_window: None, exit_condition: ExitCondition::DontExit, ..default() }).disable::<bevy::log::LogPlugin>(),
        ),
        PhonationPlugin,
        phonation::plugin::PhonationGpuPlugin,
    ));
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
    }
    app.finish();
    app.cleanup();
    Some(app)
}

pub(crate) fn app() -> App {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, PhonationPlugin));
    app
}

/// A headless app with the renderer (lavapipe in CI), no window, the drawing plugins without the
/// panel plus `extra`, a camera rendering the first simulation into a `w` × `h` image on a dark
/// background: the app, the image and the background as sRGB bytes.
#[cfg(feature = "render")]
pub(crate) fn headless_render_app<M>(extra: impl bevy::app::Plugins<M>, w: u32, h: u32) -> (App, Handle<Image>, [i32; 3]) {
    use bevy::app::PluginsState;
    use bevy::asset::RenderAssetUsages;
    use bevy::camera::RenderTarget;
    use bevy::render::render_resource::{Extent3d, TextureDimension, TextureFormat, TextureUsages};
    use bevy::window::{ExitCondition, WindowPlugin};
    use phonation::render::PhonationPlugins;
    use phonation::render::panel::PanelPlugin;
    use phonation::render::view::FrameSimulation;
    let mut app = App::new();
    app.add_plugins((
        headless_default_plugins(
            DefaultPlugins
                .set(WindowPlugin { primary_window: None, exit_condition: ExitCondition::DontExit, ..default() })
                .set(bevy::render::RenderPlugin { synchronous_pipeline_compilation: true, ..default() })
                .disable::<bevy::log::LogPlugin>(),
        ),
        PhonationPlugins.build().disable::<PanelPlugin>(),
    ))
    .add_plugins(extra);
    while app.plugins_state() == PluginsState::Adding {
        bevy::tasks::tick_global_task_pools_on_main_thread();
    }
    app.finish();
    app.cleanup();
    let mut target = Image::new_uninit(
        Extent3d { width: w, height: h, depth_or_array_layers: 1 },
        TextureDimension::D2,
        TextureFormat::Rgba8UnormSrgb,
        RenderAssetUsages::RENDER_WORLD,
    );
    target.texture_descriptor.usage |= TextureUsages::RENDER_ATTACHMENT;
    let handle = app.world_mut().resource_mut::<Assets<Image>>().add(target);
    let background = Color::srgb(0.08, 0.08, 0.1);
    app.insert_resource(ClearColor(background));
    app.world_mut().spawn((Camera3d::default(), RenderTarget::from(handle.clone()), FrameSimulation));
    let bg = background.to_srgba();
    (app, handle, [bg.red, bg.green, bg.blue].map(|c| (c * 255.0).round() as i32))
}

/// A frame's pixels (RGBA8, sRGB) of the app's image `target`, after three more frames; also
/// saved as `name` (PNG) in the test's target directory.
#[cfg(feature = "render")]
pub(crate) fn capture(app: &mut App, target: &Handle<Image>, name: &str) -> Vec<u8> {
    use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
    use std::sync::{Arc, Mutex};
    for _ in 0..3 {
        app.update();
    }
    let got: Arc<Mutex<Option<Image>>> = Arc::default();
    let sink = got.clone();
    app.world_mut().spawn(Screenshot::image(target.clone())).observe(move |c: On<ScreenshotCaptured>| {
        *sink.lock().unwrap() = Some(c.image.clone());
    });
    for _ in 0..30 {
        app.update();
        if got.lock().unwrap().is_some() {
            break;
        }
    }
    let img = got.lock().unwrap().take().expect("a screenshot within 30 frames");
    img.clone().try_into_dynamic().expect("an RGBA image").to_rgb8().save(std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join(name)).unwrap();
    img.data.expect("pixels")
}

pub(crate) fn sim_nodes(app: &App, e: Entity) -> [usize; 3] {
    app.world().get::<FluidSimulation>(e).unwrap().solver.layout.grid.n
}

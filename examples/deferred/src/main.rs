//! `deferred`: the example renderer in a window, or headless with `--frames N --screenshot`.
//! Keys: `T` next GI technique, `G` indirect light on/off, `Esc` quit.

use anyhow::{Context, Result};
use clap::Parser;
use octolux_example_deferred::{create_device, model::Model, Example, TECHNIQUES};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::{ElementState, KeyEvent, WindowEvent};
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::keyboard::{Key, NamedKey};
use winit::window::{Window, WindowId};

#[derive(Parser)]
#[command(
    about = "A deferred wgpu renderer of its own, with octolux's GI added through octolux::embed"
)]
struct Args {
    /// The glTF file to draw (its node called "block" moves, its first point light circles).
    #[arg(long, default_value = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/room.gltf"))]
    gltf: PathBuf,
    /// The GI technique to start with (T switches in the window).
    #[arg(long, default_value = octolux::gi::DEFAULT_TECHNIQUE)]
    technique: String,
    /// Width in pixels.
    #[arg(long, default_value_t = 960)]
    width: u32,
    /// Height in pixels.
    #[arg(long, default_value_t = 540)]
    height: u32,
    /// Headless: render this many frames (30 per second of animation) and exit.
    #[arg(long)]
    frames: Option<u32>,
    /// Headless: write the last frame to this PNG.
    #[arg(long)]
    screenshot: Option<PathBuf>,
}

fn main() {
    if let Err(e) = run(Args::parse()) {
        eprintln!("error: {e:#}");
        std::process::exit(1);
    }
}

fn run(args: Args) -> Result<()> {
    let model = Model::load(&args.gltf)?;
    let instance =
        wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
    if args.frames.is_some() || args.screenshot.is_some() {
        return headless(&instance, model, &args);
    }
    let event_loop = EventLoop::new()
        .context("cannot open a window (no display? try --frames 10 --screenshot out.png)")?;
    let mut app = App {
        args,
        instance,
        model: Some(model),
        state: None,
        error: None,
    };
    event_loop.run_app(&mut app)?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

fn headless(instance: &wgpu::Instance, model: Model, args: &Args) -> Result<()> {
    let (_adapter, device, queue) = create_device(instance)?;
    let mut example = Example::new(
        &device,
        &queue,
        model,
        args.width,
        args.height,
        wgpu::TextureFormat::Rgba8UnormSrgb,
        &args.technique,
    )?;
    let frames = args.frames.unwrap_or(10);
    let image = example.run_headless(frames)?;
    // Timestamps of the frames come back a frame or two later.
    device.poll(wgpu::PollType::wait_indefinitely())?;
    if let Some(timings) = example.gi.take_timings()? {
        let total: f64 = timings.iter().map(|t| t.ms).sum();
        println!("octolux GI: {total:.3} ms over {} passes", timings.len());
    }
    println!(
        "{frames} frames of {} with {}; octolux GPU memory {:.1} MiB",
        args.gltf.display(),
        args.technique,
        example.gi.memory().total() as f64 / (1 << 20) as f64
    );
    if let Some(path) = &args.screenshot {
        image
            .save(path)
            .with_context(|| format!("cannot write {}", path.display()))?;
        println!("screenshot: {}", path.display());
    }
    Ok(())
}

struct Windowed {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    device: wgpu::Device,
    queue: wgpu::Queue,
    example: Example,
    technique: usize,
    start: Instant,
}

struct App {
    args: Args,
    instance: wgpu::Instance,
    model: Option<Model>,
    state: Option<Windowed>,
    error: Option<anyhow::Error>,
}

impl App {
    fn open(&mut self, event_loop: &ActiveEventLoop) -> Result<()> {
        let Some(model) = self.model.take() else {
            return Ok(());
        };
        let attributes = Window::default_attributes()
            .with_title("octolux embedding example")
            .with_resizable(false)
            .with_inner_size(winit::dpi::PhysicalSize::new(
                self.args.width,
                self.args.height,
            ));
        let window = Arc::new(event_loop.create_window(attributes)?);
        let surface = self.instance.create_surface(window.clone())?;
        let (adapter, device, queue) = create_device(&self.instance)?;
        let size = window.inner_size();
        let mut config = surface
            .get_default_config(&adapter, size.width.max(1), size.height.max(1))
            .context("the adapter cannot draw into this window")?;
        config.format = config.format.add_srgb_suffix();
        surface.configure(&device, &config);
        let technique = TECHNIQUES
            .iter()
            .position(|t| *t == self.args.technique)
            .unwrap_or(0);
        let example = Example::new(
            &device,
            &queue,
            model,
            config.width,
            config.height,
            config.format,
            TECHNIQUES[technique],
        )?;
        self.state = Some(Windowed {
            window,
            surface,
            config,
            device,
            queue,
            example,
            technique,
            start: Instant::now(),
        });
        Ok(())
    }

    fn redraw(&mut self) -> Result<()> {
        let Some(s) = &mut self.state else {
            return Ok(());
        };
        let texture = match s.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            _ => {
                s.surface.configure(&s.device, &s.config);
                return Ok(());
            }
        };
        let view = texture.texture.create_view(&Default::default());
        s.example.frame(s.start.elapsed().as_secs_f32(), &view)?;
        s.window.pre_present_notify();
        s.queue.present(texture);
        if let Some(timings) = s.example.gi.take_timings()? {
            let total: f64 = timings.iter().map(|t| t.ms).sum();
            s.window.set_title(&format!(
                "octolux embedding example: {} {total:.2} ms (T: next technique, G: indirect on/off)",
                TECHNIQUES[s.technique]
            ));
        }
        s.window.request_redraw();
        Ok(())
    }

    fn key(&mut self, key: &Key) -> Result<()> {
        let Some(s) = &mut self.state else {
            return Ok(());
        };
        match key {
            Key::Character(c) if c.eq_ignore_ascii_case("t") => {
                s.technique = (s.technique + 1) % TECHNIQUES.len();
                let name = TECHNIQUES[s.technique];
                s.example.gi.set_technique(name, &Default::default())?;
                s.window
                    .set_title(&format!("octolux embedding example: {name}"));
            }
            Key::Character(c) if c.eq_ignore_ascii_case("g") => {
                s.example.indirect_on = !s.example.indirect_on;
            }
            _ => {}
        }
        Ok(())
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if let Err(e) = self.open(event_loop) {
            self.error = Some(e);
            event_loop.exit();
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        let result = match event {
            WindowEvent::CloseRequested => {
                event_loop.exit();
                Ok(())
            }
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        logical_key,
                        state: ElementState::Pressed,
                        ..
                    },
                ..
            } => {
                if logical_key == Key::Named(NamedKey::Escape) {
                    event_loop.exit();
                }
                self.key(&logical_key)
            }
            WindowEvent::RedrawRequested => self.redraw(),
            _ => Ok(()),
        };
        if let Err(e) = result {
            self.error = Some(e);
            event_loop.exit();
        }
    }
}

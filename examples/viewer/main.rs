//! An interactive viewer: any scene (bundled name or glTF path, with a lighting file) in a
//! window, rendered by one GI tier at a time on the window's device and shown from the
//! renderer's output texture, with a fly camera and the frame's pass timings on screen.
//!
//! ```text
//! cargo run --release -p gi-examples --bin viewer -- [scene] [--lighting FILE]
//!     [--tier auto|reference|direct|path|mobile|pc] [--size 960x540] [--spp N] [--exposure E]
//!     [--frames N] [--screenshot shot.png]
//! ```
//!
//! Keys: W A S D fly, Q E down and up, Shift faster, arrows or a left-button drag look
//! around; 0 auto, 1 reference, 2 direct, 3 path, 4 mobile, 5 pc switch the tier; - and =
//! change the exposure; Tab hides the text; F12 saves a screenshot; Esc quits. With `--frames N` the viewer renders N frames on a fixed
//! timeline, saves `--screenshot` if given, and exits: how CI runs it under Xvfb.

use std::{
    collections::HashSet,
    error::Error,
    path::{Path, PathBuf},
    process::ExitCode,
    sync::Arc,
    time::Instant,
};

use ab_glyph::{Font, FontRef, PxScale, ScaleFont};
use clap::Parser;
use gi_gpu::{GpuContext, wgpu};
use gi_scene::{CameraView, Scene};
use gi_tiers::{FrameRequest, Renderer, TierChoice, TierKind};
use glam::Vec3;
use winit::{
    application::ApplicationHandler,
    dpi::PhysicalSize,
    event::{ElementState, MouseButton, WindowEvent},
    event_loop::{ActiveEventLoop, EventLoop},
    keyboard::{KeyCode, PhysicalKey},
    window::{Window, WindowId},
};

/// The overlay's font (DejaVu Sans, its license beside it in `benchmarks/assets`).
const FONT: &[u8] = include_bytes!("../../benchmarks/assets/DejaVuSans.ttf");
/// Text height in pixels.
const TEXT_PX: f32 = 15.0;
/// Seconds between two updates of the overlay's timings.
const OVERLAY_PERIOD_S: f32 = 0.25;

/// Shows a scene in a window, rendered by one GI tier at a time.
#[derive(Parser)]
struct Args {
    /// A bundled scene name or a glTF path.
    #[arg(default_value = "cornell-box")]
    scene: String,
    /// A lighting file (sun, sky, exposure) for a scene without lights.
    #[arg(long)]
    lighting: Option<PathBuf>,
    /// `auto` or a tier name (reference, direct, path, mobile, pc).
    #[arg(long, default_value = "auto")]
    tier: TierChoice,
    /// Window and render size, `WxH`.
    #[arg(long, default_value = "960x540", value_parser = parse_size)]
    size: (u32, u32),
    /// Samples per pixel per frame.
    #[arg(long, default_value_t = 1)]
    spp: u32,
    /// Exposure (default: the scene's).
    #[arg(long)]
    exposure: Option<f32>,
    /// Render this many frames on a fixed timeline, then exit.
    #[arg(long)]
    frames: Option<u32>,
    /// With `--frames`: save the last frame as the window shows it.
    #[arg(long)]
    screenshot: Option<PathBuf>,
}

fn parse_size(text: &str) -> Result<(u32, u32), String> {
    text.split_once('x')
        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        .filter(|&(w, h): &(u32, u32)| w > 0 && h > 0)
        .ok_or(format!("{text:?}: expected WxH"))
}

/// A camera flown by keys and mouse: a position and a heading.
struct FlyCamera {
    position: Vec3,
    yaw: f32,
    pitch: f32,
    yfov: f32,
    /// Meters per second, from the scene's size.
    speed: f32,
}

impl FlyCamera {
    fn new(view: CameraView, extent: f32) -> Self {
        Self {
            position: view.position,
            yaw: view.forward.x.atan2(-view.forward.z),
            pitch: view.forward.y.clamp(-1.0, 1.0).asin(),
            yfov: view.yfov,
            speed: (extent * 0.25).max(0.1),
        }
    }

    fn forward(&self) -> Vec3 {
        let (sy, cy) = self.yaw.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(cp * sy, sp, -cp * cy)
    }

    fn view(&self) -> CameraView {
        CameraView::look_at(self.position, self.position + self.forward(), self.yfov)
    }

    fn look(&mut self, yaw: f32, pitch: f32) {
        self.yaw += yaw;
        self.pitch = (self.pitch + pitch).clamp(-1.5, 1.5);
    }

    fn fly(&mut self, keys: &HashSet<KeyCode>, dt: f32) {
        let held = |key| keys.contains(&key);
        let forward = self.forward();
        let right = forward.cross(Vec3::Y).normalize_or(Vec3::X);
        let mut step = Vec3::ZERO;
        for (key, direction) in [
            (KeyCode::KeyW, forward),
            (KeyCode::KeyS, -forward),
            (KeyCode::KeyD, right),
            (KeyCode::KeyA, -right),
            (KeyCode::KeyE, Vec3::Y),
            (KeyCode::KeyQ, -Vec3::Y),
        ] {
            if held(key) {
                step += direction;
            }
        }
        let fast = if held(KeyCode::ShiftLeft) || held(KeyCode::ShiftRight) {
            4.0
        } else {
            1.0
        };
        self.position += step.normalize_or_zero() * self.speed * fast * dt;
        let turn = 1.5 * dt;
        for (key, yaw, pitch) in [
            (KeyCode::ArrowLeft, -turn, 0.0),
            (KeyCode::ArrowRight, turn, 0.0),
            (KeyCode::ArrowUp, 0.0, turn),
            (KeyCode::ArrowDown, 0.0, -turn),
        ] {
            if held(key) {
                self.look(yaw, pitch);
            }
        }
    }
}

/// Text rasterized on the CPU into an RGBA8 image (white glyphs over a dark box).
struct TextImage {
    width: u32,
    height: u32,
    pixels: Vec<u8>,
}

fn rasterize(font: &FontRef<'_>, lines: &[String]) -> TextImage {
    let scaled = font.as_scaled(PxScale::from(TEXT_PX));
    let line_height = scaled.height().ceil() + 2.0;
    let width = lines
        .iter()
        .map(|line| {
            line.chars()
                .map(|c| scaled.h_advance(font.glyph_id(c)))
                .sum::<f32>()
        })
        .fold(0.0f32, f32::max)
        .ceil() as u32
        + 12;
    let height = (line_height * lines.len() as f32).ceil() as u32 + 8;
    let mut pixels = vec![0u8; (width * height * 4) as usize];
    for px in pixels.chunks_exact_mut(4) {
        px.copy_from_slice(&[0, 0, 0, 150]);
    }
    for (row, line) in lines.iter().enumerate() {
        let mut x = 6.0;
        let baseline = 4.0 + scaled.ascent() + line_height * row as f32;
        for c in line.chars() {
            let id = font.glyph_id(c);
            let glyph = id.with_scale_and_position(TEXT_PX, ab_glyph::point(x, baseline));
            x += scaled.h_advance(id);
            let Some(outlined) = font.outline_glyph(glyph) else {
                continue;
            };
            let bounds = outlined.px_bounds();
            outlined.draw(|gx, gy, coverage| {
                let px = bounds.min.x as i64 + i64::from(gx);
                let py = bounds.min.y as i64 + i64::from(gy);
                if px < 0 || py < 0 || px >= i64::from(width) || py >= i64::from(height) {
                    return;
                }
                let at = ((py as u32 * width + px as u32) * 4) as usize;
                let value = (coverage.clamp(0.0, 1.0) * 255.0) as u8;
                let pixel = &mut pixels[at..at + 4];
                let alpha = pixel[3].max(value);
                let grey = pixel[0].max(value);
                pixel.copy_from_slice(&[grey, grey, grey, alpha]);
            });
        }
    }
    TextImage {
        width,
        height,
        pixels,
    }
}

/// The window's surface, its device (which the renderer renders on) and the blit.
struct Display {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    engine: GpuContext,
    pipeline: wgpu::RenderPipeline,
    screenshot_pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    params: wgpu::Buffer,
    params_srgb: wgpu::Buffer,
    overlay: wgpu::Texture,
    /// The frame of a tier that renders on the CPU, uploaded.
    cpu_frame: Option<wgpu::Texture>,
}

/// The format the viewer's screenshots are drawn in, then read back.
const SCREENSHOT_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

impl Display {
    fn new(window: Arc<Window>) -> Result<Self, Box<dyn Error>> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN,
            ..wgpu::InstanceDescriptor::new_without_display_handle_from_env()
        });
        let surface = instance.create_surface(window.clone())?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            compatible_surface: Some(&surface),
            ..Default::default()
        }))?;
        let timestamps = wgpu::Features::TIMESTAMP_QUERY
            | wgpu::Features::TIMESTAMP_QUERY_INSIDE_ENCODERS
            | wgpu::Features::TIMESTAMP_QUERY_INSIDE_PASSES;
        let (device, queue) =
            pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
                label: Some("viewer"),
                required_features: adapter.features() & timestamps,
                required_limits: adapter.limits(),
                ..Default::default()
            }))?;
        let engine = GpuContext::from_device(&adapter, device, queue);
        let size = window.inner_size();
        let caps = surface.get_capabilities(&adapter);
        let format = *caps.formats.first().ok_or("the surface offers no format")?;
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::Fifo,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes[0],
            view_formats: vec![],
            color_space: wgpu::SurfaceColorSpace::Auto,
        };
        surface.configure(&engine.device, &config);

        let device = &engine.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("viewer/blit"),
            source: wgpu::ShaderSource::Wgsl(include_str!("blit.wgsl").into()),
        });
        let texture_entry = |binding| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::FRAGMENT,
            ty: wgpu::BindingType::Texture {
                sample_type: wgpu::TextureSampleType::Float { filterable: false },
                view_dimension: wgpu::TextureViewDimension::D2,
                multisampled: false,
            },
            count: None,
        };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("viewer/blit.layout"),
            entries: &[
                texture_entry(0),
                texture_entry(1),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("viewer/blit"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |format: wgpu::TextureFormat| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("viewer/blit"),
                layout: Some(&pipeline_layout),
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs"),
                    compilation_options: Default::default(),
                    buffers: &[],
                },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs"),
                    compilation_options: Default::default(),
                    targets: &[Some(format.into())],
                }),
                primitive: Default::default(),
                depth_stencil: None,
                multisample: Default::default(),
                multiview_mask: None,
                cache: None,
            })
        };
        let params = || {
            engine.create_buffer(
                "viewer.params",
                16,
                wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            )
        };
        let overlay = overlay_texture(&engine, 1, 1);
        let display = Self {
            pipeline: pipeline(format),
            screenshot_pipeline: pipeline(SCREENSHOT_FORMAT),
            params: params(),
            params_srgb: params(),
            window,
            surface,
            config,
            layout,
            overlay,
            cpu_frame: None,
            engine,
        };
        display.set_exposure(1.0);
        Ok(display)
    }

    fn resize(&mut self, size: PhysicalSize<u32>) {
        self.config.width = size.width.max(1);
        self.config.height = size.height.max(1);
        self.surface.configure(&self.engine.device, &self.config);
    }

    /// Writes the blit's parameters: `exposure`, and whether the shader encodes sRGB (for
    /// the window: unless its format does; for screenshots: always).
    fn set_exposure(&self, exposure: f32) {
        let window_encodes = u32::from(!self.config.format.is_srgb());
        for (buffer, encode) in [(&self.params, window_encodes), (&self.params_srgb, 1)] {
            let mut bytes = Vec::with_capacity(16);
            bytes.extend(exposure.to_le_bytes());
            bytes.extend(u32::to_le_bytes(encode));
            bytes.extend([0u8; 8]);
            self.engine.queue.write_buffer(buffer, 0, &bytes);
        }
    }

    fn set_overlay(&mut self, text: &TextImage) {
        let size = self.overlay.size();
        if (size.width, size.height) != (text.width, text.height) {
            self.overlay.destroy();
            self.overlay = overlay_texture(&self.engine, text.width, text.height);
        }
        self.engine.queue.write_texture(
            self.overlay.as_image_copy(),
            &text.pixels,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(text.width * 4),
                rows_per_image: Some(text.height),
            },
            self.overlay.size(),
        );
    }

    /// Uploads a CPU tier's frame.
    fn upload(&mut self, image: &gi_image::Image) -> wgpu::TextureView {
        let size = wgpu::Extent3d {
            width: image.width,
            height: image.height,
            depth_or_array_layers: 1,
        };
        let fits = self.cpu_frame.as_ref().is_some_and(|t| t.size() == size);
        if !fits {
            self.cpu_frame = Some(self.engine.device.create_texture(&wgpu::TextureDescriptor {
                label: Some("viewer.cpu_frame"),
                size,
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::Rgba32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            }));
        }
        let texture = self.cpu_frame.as_ref().expect("made above");
        let texels: Vec<f32> = image
            .pixels
            .iter()
            .flat_map(|p| p.extend(1.0).to_array())
            .collect();
        let bytes: Vec<u8> = texels.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.engine.queue.write_texture(
            texture.as_image_copy(),
            &bytes,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(image.width * 16),
                rows_per_image: Some(image.height),
            },
            size,
        );
        texture.create_view(&Default::default())
    }

    fn bind_group(&self, frame: &wgpu::TextureView, params: &wgpu::Buffer) -> wgpu::BindGroup {
        let overlay = self.overlay.create_view(&Default::default());
        self.engine
            .device
            .create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("viewer/blit.group"),
                layout: &self.layout,
                entries: &[
                    wgpu::BindGroupEntry {
                        binding: 0,
                        resource: wgpu::BindingResource::TextureView(frame),
                    },
                    wgpu::BindGroupEntry {
                        binding: 1,
                        resource: wgpu::BindingResource::TextureView(&overlay),
                    },
                    wgpu::BindGroupEntry {
                        binding: 2,
                        resource: params.as_entire_binding(),
                    },
                ],
            })
    }

    fn draw(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
        pipeline: &wgpu::RenderPipeline,
        group: &wgpu::BindGroup,
    ) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("viewer/blit"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            ..Default::default()
        });
        pass.set_pipeline(pipeline);
        pass.set_bind_group(0, group, &[]);
        pass.draw(0..3, 0..1);
    }

    /// Shows `frame` in the window.
    fn present(&self, frame: &wgpu::TextureView) -> Result<(), Box<dyn Error>> {
        let output = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(texture)
            | wgpu::CurrentSurfaceTexture::Suboptimal(texture) => texture,
            other => return Err(format!("no surface texture: {other:?}").into()),
        };
        let view = output.texture.create_view(&Default::default());
        let group = self.bind_group(frame, &self.params);
        let mut encoder = self.engine.create_encoder("viewer/present");
        self.draw(&mut encoder, &view, &self.pipeline, &group);
        self.engine.queue.submit([encoder.finish()]);
        self.window.pre_present_notify();
        self.engine.queue.present(output);
        Ok(())
    }

    /// Draws `frame` as the window shows it into a texture of the window's size and saves it
    /// as a PNG.
    fn screenshot(&self, frame: &wgpu::TextureView, path: &Path) -> Result<(), Box<dyn Error>> {
        let (width, height) = (self.config.width, self.config.height);
        let target = self.engine.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("viewer.screenshot"),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: SCREENSHOT_FORMAT,
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        });
        let row = (width * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
        let buffer = self.engine.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("viewer.screenshot"),
            size: u64::from(row) * u64::from(height),
            usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let group = self.bind_group(frame, &self.params_srgb);
        let mut encoder = self.engine.create_encoder("viewer/screenshot");
        let view = target.create_view(&Default::default());
        self.draw(&mut encoder, &view, &self.screenshot_pipeline, &group);
        encoder.copy_texture_to_buffer(
            target.as_image_copy(),
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(row),
                    rows_per_image: Some(height),
                },
            },
            target.size(),
        );
        self.engine.queue.submit([encoder.finish()]);
        let bytes: Vec<u8> = self.engine.try_read_buffer(&buffer)?;
        let pixels: Vec<u8> = bytes
            .chunks_exact(row as usize)
            .flat_map(|line| line[..(width * 4) as usize].to_vec())
            .collect();
        let image = image::RgbaImage::from_raw(width, height, pixels).ok_or("screenshot size")?;
        image.save(path)?;
        Ok(())
    }
}

fn overlay_texture(engine: &GpuContext, width: u32, height: u32) -> wgpu::Texture {
    engine.device.create_texture(&wgpu::TextureDescriptor {
        label: Some("viewer.overlay"),
        size: wgpu::Extent3d {
            width,
            height,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: wgpu::TextureFormat::Rgba8Unorm,
        usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        view_formats: &[],
    })
}

/// Everything the viewer keeps between frames.
struct Viewer {
    display: Display,
    scene: Scene,
    renderer: Renderer,
    camera: FlyCamera,
    keys: HashSet<KeyCode>,
    dragging: bool,
    cursor: Option<(f64, f64)>,
    started: Instant,
    last_frame: Instant,
    frames: u32,
    font: FontRef<'static>,
    overlay_age: f32,
    passes: Vec<(String, f64)>,
    frame_ms: f32,
    exposure: f32,
    screenshot_requested: bool,
    /// Whether the text overlay shows (Tab toggles it).
    overlay: bool,
}

impl Viewer {
    fn new(window: Arc<Window>, args: &Args) -> Result<Self, Box<dyn Error>> {
        let loaded = gi_scene::load_with_lighting(&args.scene, args.lighting.as_deref())?;
        for warning in &loaded.warnings {
            eprintln!("warning: {warning}");
        }
        let scene = loaded.scene;
        let display = Display::new(window)?;
        let exposure = args.exposure.unwrap_or(scene.exposure);
        display.set_exposure(exposure);
        let renderer = make_renderer(&scene, args.tier, args, &display.engine)?;
        let bounds = scene_extent(&scene);
        let camera = FlyCamera::new(renderer.view(0), bounds);
        Ok(Self {
            display,
            scene,
            renderer,
            camera,
            keys: HashSet::new(),
            dragging: false,
            cursor: None,
            started: Instant::now(),
            last_frame: Instant::now(),
            frames: 0,
            font: FontRef::try_from_slice(FONT)?,
            overlay_age: f32::INFINITY,
            passes: Vec::new(),
            frame_ms: 0.0,
            exposure,
            screenshot_requested: false,
            overlay: true,
        })
    }

    fn switch_tier(&mut self, choice: TierChoice, args: &Args) {
        match make_renderer(&self.scene, choice, args, &self.display.engine) {
            Ok(renderer) => {
                println!("tier: {}", describe(&renderer));
                self.renderer = renderer;
                self.passes.clear();
                self.overlay_age = f32::INFINITY;
            }
            Err(error) => eprintln!("cannot switch the tier: {error}"),
        }
    }

    /// Renders and shows one frame at `time_s`; saves the screenshot to `screenshot` if one
    /// was asked for.
    fn frame(&mut self, time_s: f32, screenshot: Option<&Path>) -> Result<(), Box<dyn Error>> {
        let now = Instant::now();
        let dt = (now - self.last_frame).as_secs_f32().min(0.25);
        self.last_frame = now;
        self.camera.fly(&self.keys, dt);
        let request = FrameRequest::at(time_s).with_camera(self.camera.view());
        let view = if self.renderer.context().is_some() {
            let reported = self.renderer.submit(&request)?;
            if let Some(latest) = reported.last() {
                self.passes = latest.passes.clone();
            }
            let textures = self
                .renderer
                .output_textures()?
                .ok_or("no output textures")?;
            textures.image.create_view(&Default::default())
        } else {
            let output = self.renderer.render(&request)?;
            self.passes = output.passes.clone();
            self.display.upload(&output.image)
        };
        self.frames += 1;
        self.frame_ms = 0.9 * self.frame_ms + 0.1 * dt * 1e3;
        self.overlay_age += dt;
        if self.overlay_age >= OVERLAY_PERIOD_S || screenshot.is_some() {
            self.overlay_age = 0.0;
            let text = if self.overlay {
                rasterize(&self.font, &self.overlay_lines())
            } else {
                TextImage {
                    width: 1,
                    height: 1,
                    pixels: vec![0; 4],
                }
            };
            self.display.set_overlay(&text);
        }
        self.display.present(&view)?;
        if let Some(path) = screenshot {
            self.display.screenshot(&view, path)?;
            println!("screenshot saved to {}", path.display());
        }
        Ok(())
    }

    fn overlay_lines(&self) -> Vec<String> {
        let mut lines = vec![
            format!(
                "{}  |  {} frames  |  {:.1} ms per frame  |  exposure {:.2}",
                describe(&self.renderer),
                self.frames,
                self.frame_ms,
                self.exposure
            ),
            "0 auto  1 reference  2 direct  3 path  4 mobile  5 pc  |  WASDQE fly  - = exposure  \
             F12 shot"
                .to_string(),
        ];
        let total: f64 = self.passes.iter().map(|(_, ms)| ms).sum();
        lines.push(format!("passes: {total:.3} ms"));
        let mut passes = self.passes.clone();
        passes.sort_by(|a, b| b.1.total_cmp(&a.1));
        for (name, ms) in passes.iter().take(8) {
            lines.push(format!("  {name}  {ms:.3} ms"));
        }
        lines
    }
}

fn describe(renderer: &Renderer) -> String {
    let device = match renderer.context() {
        Some(ctx) => ctx.adapter_info.name.clone(),
        None => "the CPU".to_string(),
    };
    format!("{} on {device}", renderer.tier())
}

/// A renderer of `scene` on the window's device at the viewer's size and samples.
fn make_renderer(
    scene: &Scene,
    choice: TierChoice,
    args: &Args,
    engine: &GpuContext,
) -> Result<Renderer, Box<dyn Error>> {
    let renderer = Renderer::builder(scene.clone())
        .tier(choice)
        .size(args.size.0, args.size.1)
        .spp(args.spp)
        .context(engine.share())
        .build()?;
    Ok(renderer)
}

/// The diagonal of the scene's bounds at time 0, in meters.
fn scene_extent(scene: &Scene) -> f32 {
    let frame = scene.evaluate(0.0, None);
    let (lo, hi) = frame.triangles.iter().fold(
        (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
        |(lo, hi), t| {
            let (a, b, c) = (Vec3::from(t.v0), Vec3::from(t.v1), Vec3::from(t.v2));
            (lo.min(a).min(b).min(c), hi.max(a).max(b).max(c))
        },
    );
    if lo.x > hi.x {
        return 1.0;
    }
    (hi - lo).length()
}

struct App {
    args: Args,
    viewer: Option<Viewer>,
    error: Option<String>,
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, error: impl std::fmt::Display) {
        self.error = Some(error.to_string());
        event_loop.exit();
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.viewer.is_some() {
            return;
        }
        let attributes = Window::default_attributes()
            .with_title("gi viewer")
            .with_inner_size(PhysicalSize::new(self.args.size.0, self.args.size.1));
        let window = match event_loop.create_window(attributes) {
            Ok(window) => Arc::new(window),
            Err(error) => return self.fail(event_loop, error),
        };
        match Viewer::new(window, &self.args) {
            Ok(viewer) => {
                println!("tier: {}", describe(&viewer.renderer));
                self.viewer = Some(viewer);
            }
            Err(error) => self.fail(event_loop, error),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        let Some(viewer) = self.viewer.as_mut() else {
            return;
        };
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => viewer.display.resize(size),
            WindowEvent::KeyboardInput { event, .. } => {
                let PhysicalKey::Code(key) = event.physical_key else {
                    return;
                };
                if event.state == ElementState::Released {
                    viewer.keys.remove(&key);
                    return;
                }
                viewer.keys.insert(key);
                let tier = match key {
                    KeyCode::Digit0 => Some(TierChoice::Auto),
                    KeyCode::Digit1 => Some(TierChoice::Tier(TierKind::Reference)),
                    KeyCode::Digit2 => Some(TierChoice::Tier(TierKind::Direct)),
                    KeyCode::Digit3 => Some(TierChoice::Tier(TierKind::Path)),
                    KeyCode::Digit4 => Some(TierChoice::Tier(TierKind::Mobile)),
                    KeyCode::Digit5 => Some(TierChoice::Tier(TierKind::Pc)),
                    _ => None,
                };
                if let Some(choice) = tier
                    && !event.repeat
                {
                    viewer.switch_tier(choice, &self.args);
                }
                match key {
                    KeyCode::Escape => event_loop.exit(),
                    KeyCode::F12 => viewer.screenshot_requested = true,
                    KeyCode::Tab => {
                        viewer.overlay = !viewer.overlay;
                        viewer.overlay_age = f32::INFINITY;
                    }
                    KeyCode::Equal | KeyCode::Minus => {
                        let factor = if key == KeyCode::Equal { 1.25 } else { 0.8 };
                        viewer.exposure *= factor;
                        viewer.display.set_exposure(viewer.exposure);
                    }
                    _ => {}
                }
            }
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Left,
                ..
            } => viewer.dragging = state == ElementState::Pressed,
            WindowEvent::CursorMoved { position, .. } => {
                if let Some((x, y)) = viewer.cursor
                    && viewer.dragging
                {
                    let (dx, dy) = ((position.x - x) as f32, (position.y - y) as f32);
                    viewer.camera.look(dx * 0.004, -dy * 0.004);
                }
                viewer.cursor = Some((position.x, position.y));
            }
            WindowEvent::RedrawRequested => {
                let automated = self.args.frames;
                let time_s = match automated {
                    Some(_) => viewer.scene.frame_time(viewer.frames),
                    None => viewer.started.elapsed().as_secs_f32(),
                };
                let last = automated.is_some_and(|n| viewer.frames + 1 >= n);
                let shot = if last {
                    self.args.screenshot.clone()
                } else if std::mem::take(&mut viewer.screenshot_requested) {
                    Some(PathBuf::from(format!("viewer-{}.png", viewer.frames)))
                } else {
                    None
                };
                if let Err(error) = viewer.frame(time_s, shot.as_deref()) {
                    return self.fail(event_loop, error);
                }
                if last {
                    let lines = viewer.overlay_lines();
                    println!("{}", lines.join("\n"));
                    event_loop.exit();
                }
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, _: &ActiveEventLoop) {
        if let Some(viewer) = &self.viewer {
            viewer.display.window.request_redraw();
        }
    }
}

fn main() -> ExitCode {
    let args = Args::parse();
    let event_loop = match EventLoop::new() {
        Ok(event_loop) => event_loop,
        Err(error) => {
            eprintln!("error: no window system ({error}); the viewer needs a display");
            return ExitCode::FAILURE;
        }
    };
    let mut app = App {
        args,
        viewer: None,
        error: None,
    };
    if let Err(error) = event_loop.run_app(&mut app) {
        eprintln!("error: {error}");
        return ExitCode::FAILURE;
    }
    match app.error {
        Some(error) => {
            eprintln!("error: {error}");
            ExitCode::FAILURE
        }
        None => ExitCode::SUCCESS,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_fly_camera_starts_where_the_view_looks() {
        let view = CameraView::look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.0, 1.0, -2.0), 0.7);
        let camera = FlyCamera::new(view, 10.0);
        assert!(camera.forward().dot(view.forward) > 1.0 - 1e-5);
        let again = camera.view();
        assert!((again.position - view.position).length() < 1e-6);
        assert!(again.up.dot(view.up) > 1.0 - 1e-5);
    }

    #[test]
    fn text_covers_pixels_over_a_dark_box() {
        let font = FontRef::try_from_slice(FONT).unwrap();
        let text = rasterize(&font, &["pc 1.234 ms".to_string()]);
        assert!(text.width > 40 && text.height >= TEXT_PX as u32);
        let lit = text.pixels.chunks_exact(4).filter(|p| p[0] > 200).count();
        assert!(lit > 20, "{lit} glyph pixels");
        assert!(text.pixels.chunks_exact(4).all(|p| p[3] >= 150));
    }
}

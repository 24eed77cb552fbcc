//! Drawing the window: egui (panel, HUD, the frame as a texture) on a wgpu device, or, where no
//! device can draw it (no Vulkan driver at all), the frame alone copied into the window by the
//! CPU (softbuffer), the HUD in the title bar and the keys still working.
//!
//! Given the frames' GPU context, the window is drawn with that very device (its instance
//! makes the window's surface): the resident frame's textures are registered with egui as
//! native textures and drawn without a copy — one device, nothing read back (issue 37, item
//! 6). Where that device cannot present to the window, the window gets a device of its own
//! and the frames come to it as bytes (a `note:` says so).

use std::num::NonZeroU32;
use std::sync::Arc;

use winit::event_loop::ActiveEventLoop;
use winit::window::Window;

use fovea_gpu::GpuContext;

use crate::error::{Result, ViewerError};
use crate::frame::ViewFrame;

/// What draws the window.
pub enum Presenter {
    /// egui on wgpu.
    Gpu(Box<GpuPresenter>),
    /// The frame alone, by the CPU.
    Soft(SoftPresenter),
}

impl Presenter {
    /// A wgpu device for the window, or, when there is none, the CPU presenter (with a
    /// `note:` saying why, unless `quiet`).
    pub fn new(
        event_loop: &ActiveEventLoop,
        window: &Arc<Window>,
        frames_device: Option<&GpuContext>,
        quiet: bool,
    ) -> Result<Self> {
        if let Some(ctx) = frames_device {
            match GpuPresenter::on(ctx, window) {
                Ok(g) => return Ok(Presenter::Gpu(Box::new(g))),
                Err(why) => {
                    if !quiet {
                        eprintln!(
                            "note: {why}: the window gets a device of its own and each frame \
                             is read back to it"
                        );
                    }
                }
            }
        }
        match GpuPresenter::new(event_loop, window) {
            Ok(g) => Ok(Presenter::Gpu(Box::new(g))),
            Err(why) => {
                let soft = SoftPresenter::new(window).map_err(|e| {
                    ViewerError::Window(format!("{why}; the software presenter failed too: {e}"))
                })?;
                if !quiet {
                    eprintln!(
                        "note: {why}: showing the frames without the panel, drawn by the CPU \
                         (the keys work; the HUD is in the title bar)"
                    );
                }
                Ok(Presenter::Soft(soft))
            }
        }
    }

    /// What draws the window, in words.
    pub fn describe(&self) -> String {
        match self {
            Presenter::Gpu(g) => g.adapter.clone(),
            Presenter::Soft(_) => "the CPU (no Vulkan device; softbuffer)".into(),
        }
    }

    /// Whether the window is drawn with the frames' own device (their textures drawn as they
    /// are, nothing read back).
    pub fn shares_frames_device(&self) -> bool {
        matches!(self, Presenter::Gpu(g) if g.shared)
    }

    /// Whether egui's panel and HUD are drawn.
    pub fn draws_egui(&self) -> bool {
        matches!(self, Presenter::Gpu(_))
    }

    /// The window's new size in pixels.
    pub fn resize(&mut self, width: u32, height: u32) {
        if let Presenter::Gpu(g) = self {
            g.config.width = width.max(1);
            g.config.height = height.max(1);
            g.surface.configure(&g.device, &g.config);
        }
    }
}

/// egui on a wgpu device.
pub struct GpuPresenter {
    surface: wgpu::Surface<'static>,
    device: wgpu::Device,
    queue: wgpu::Queue,
    config: wgpu::SurfaceConfiguration,
    renderer: egui_wgpu::Renderer,
    adapter: String,
    /// Drawn with the frames' device ([`GpuPresenter::on`]).
    shared: bool,
}

impl GpuPresenter {
    /// The best adapter that can present to `window`; the error says why there is none.
    fn new(
        event_loop: &ActiveEventLoop,
        window: &Arc<Window>,
    ) -> std::result::Result<Self, String> {
        let desc = wgpu::InstanceDescriptor {
            display: Some(Box::new(event_loop.owned_display_handle())),
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        }
        .with_env();
        let instance = wgpu::Instance::new(desc);
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| format!("wgpu cannot draw into the window ({e})"))?;
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            compatible_surface: Some(&surface),
            force_fallback_adapter: false,
            apply_limit_buckets: false,
        }))
        .map_err(|e| {
            format!(
                "no Vulkan device can draw the window ({e}; Debian's mesa-vulkan-drivers gives \
                 the software lavapipe)"
            )
        })?;
        let info = adapter.get_info();
        let name = format!("{} ({:?}, {})", info.name, info.backend, info.driver);
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("fovea-view"),
            ..Default::default()
        }))
        .map_err(|e| format!("cannot open {name} ({e})"))?;
        let caps = surface.get_capabilities(&adapter);
        let format = egui_wgpu::preferred_framebuffer_format(&caps.formats)
            .map_err(|e| format!("{name} has no surface format for egui ({e})"))?;
        let px = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            format,
            view_formats: vec![format],
            ..surface
                .get_default_config(&adapter, px.width.max(1), px.height.max(1))
                .ok_or_else(|| format!("{name} cannot present to this window"))?
        };
        surface.configure(&device, &config);
        let renderer = egui_wgpu::Renderer::new(&device, format, Default::default());
        Ok(Self {
            surface,
            device,
            queue,
            config,
            renderer,
            adapter: name,
            shared: false,
        })
    }

    /// The window drawn with the frames' device `ctx`: the surface made by its instance,
    /// configured on its adapter; the error says why that adapter cannot present to it.
    fn on(ctx: &GpuContext, window: &Arc<Window>) -> std::result::Result<Self, String> {
        let name = ctx.adapter().to_string();
        let surface = ctx
            .instance()
            .create_surface(window.clone())
            .map_err(|e| format!("the frames' device {name} cannot draw into the window ({e})"))?;
        if !ctx.can_present_to(&surface) {
            return Err(format!(
                "the frames' device {name} cannot present to the window"
            ));
        }
        let caps = ctx.surface_capabilities(&surface);
        let format = egui_wgpu::preferred_framebuffer_format(&caps.formats)
            .map_err(|e| format!("{name} has no surface format for egui ({e})"))?;
        let px = window.inner_size();
        let config = wgpu::SurfaceConfiguration {
            format,
            view_formats: vec![format],
            ..ctx
                .surface_config(&surface, px.width.max(1), px.height.max(1))
                .ok_or_else(|| format!("{name} cannot present to this window"))?
        };
        let device = ctx.device().clone();
        surface.configure(&device, &config);
        let renderer = egui_wgpu::Renderer::new(&device, format, Default::default());
        Ok(Self {
            surface,
            device,
            queue: ctx.queue().clone(),
            config,
            renderer,
            adapter: format!("{name}, the frames' own device"),
            shared: true,
        })
    }

    /// Whether the window is drawn with the frames' own device.
    pub fn shares_frames_device(&self) -> bool {
        self.shared
    }

    /// Forgets a texture [`Self::frame_texture`] registered.
    pub fn free_frame_texture(&mut self, id: egui::TextureId) {
        self.renderer.free_texture(&id);
    }

    /// `texture` (on this presenter's device: the resident frame's) as an egui texture:
    /// registered the first time, its binding replaced when `id` names an earlier one.
    pub fn frame_texture(
        &mut self,
        texture: &wgpu::Texture,
        id: Option<egui::TextureId>,
    ) -> egui::TextureId {
        let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
        match id {
            Some(id) => {
                self.renderer.update_egui_texture_from_wgpu_texture(
                    &self.device,
                    &view,
                    wgpu::FilterMode::Linear,
                    id,
                );
                id
            }
            None => {
                self.renderer
                    .register_native_texture(&self.device, &view, wgpu::FilterMode::Linear)
            }
        }
    }

    /// Draws egui's output.
    pub fn present(
        &mut self,
        ctx: &egui::Context,
        window: &Window,
        output: egui::FullOutput,
    ) -> Result<()> {
        let jobs = ctx.tessellate(output.shapes, output.pixels_per_point);
        for (id, deltas) in &output.textures_delta.set {
            for delta in deltas {
                self.renderer
                    .update_texture(&self.device, &self.queue, *id, delta);
            }
        }
        let sd = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [self.config.width, self.config.height],
            pixels_per_point: output.pixels_per_point,
        };
        let surface_texture = match self.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                self.surface.configure(&self.device, &self.config);
                return Ok(());
            }
            _ => return Ok(()),
        };
        let mut encoder = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("fovea-view"),
            });
        self.renderer
            .update_buffers(&self.device, &self.queue, &mut encoder, &jobs, &sd);
        let target = surface_texture
            .texture
            .create_view(&wgpu::TextureViewDescriptor::default());
        {
            let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("egui"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &target,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                    depth_slice: None,
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            self.renderer
                .render(&mut pass.forget_lifetime(), &jobs, &sd);
        }
        self.queue.submit([encoder.finish()]);
        window.pre_present_notify();
        self.queue.present(surface_texture);
        for id in &output.textures_delta.free {
            self.renderer.free_texture(id);
        }
        Ok(())
    }

    /// The largest texture side the device takes.
    pub fn max_texture_side(&self) -> usize {
        self.device.limits().max_texture_dimension_2d as usize
    }
}

/// The frame copied into the window by the CPU.
pub struct SoftPresenter {
    surface: softbuffer::Surface<Arc<Window>, Arc<Window>>,
    _context: softbuffer::Context<Arc<Window>>,
}

impl SoftPresenter {
    fn new(window: &Arc<Window>) -> std::result::Result<Self, softbuffer::SoftBufferError> {
        let context = softbuffer::Context::new(window.clone())?;
        let surface = softbuffer::Surface::new(&context, window.clone())?;
        Ok(Self {
            surface,
            _context: context,
        })
    }

    /// Draws `frame` (if any) fitted into the window, black around it, with the gaze marked;
    /// returns where the frame went, in window pixels.
    pub fn present(&mut self, window: &Window, frame: Option<&ViewFrame>) -> Result<egui::Rect> {
        let size = window.inner_size();
        let (Some(w), Some(h)) = (NonZeroU32::new(size.width), NonZeroU32::new(size.height)) else {
            return Ok(egui::Rect::NOTHING);
        };
        let err = |e: softbuffer::SoftBufferError| {
            ViewerError::Window(format!("drawing the window: {e}"))
        };
        self.surface.resize(w, h).map_err(err)?;
        let mut buf = self.surface.buffer_mut().map_err(err)?;
        buf.fill(0);
        let (ww, wh) = (size.width as usize, size.height as usize);
        let mut rect = egui::Rect::NOTHING;
        if let Some(f) = frame.filter(|f| !f.rgba.is_empty()) {
            let r = fit(
                egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(ww as f32, wh as f32)),
                f.width,
                f.height,
            );
            rect = r;
            let (x0, y0) = (r.min.x.max(0.0) as usize, r.min.y.max(0.0) as usize);
            let (x1, y1) = ((r.max.x as usize).min(ww), (r.max.y as usize).min(wh));
            let (sx, sy) = (f.width as f32 / r.width(), f.height as f32 / r.height());
            for y in y0..y1 {
                let fy = (((y - y0) as f32 + 0.5) * sy) as usize;
                let src_row = &f.rgba[fy.min(f.height as usize - 1) * f.width as usize * 4..];
                for x in x0..x1 {
                    let fx = ((((x - x0) as f32 + 0.5) * sx) as usize).min(f.width as usize - 1);
                    let p = &src_row[fx * 4..fx * 4 + 3];
                    buf[y * ww + x] =
                        (u32::from(p[0]) << 16) | (u32::from(p[1]) << 8) | u32::from(p[2]);
                }
            }
            // The gaze: a small cross, in each eye's half.
            let eyes = f.eyes();
            let g = &f.request.gaze;
            let k = r.width() / eyes as f32 / f.request.display.width_px as f32;
            for e in 0..eyes {
                let cx = r.min.x + e as f32 * r.width() / eyes as f32 + g.x_px as f32 * k;
                let cy = r.min.y + g.y_px as f32 * k;
                for d in -6i32..=6 {
                    for (x, y) in [(cx + d as f32, cy), (cx, cy + d as f32)] {
                        if x >= 0.0 && y >= 0.0 && (x as usize) < ww && (y as usize) < wh {
                            buf[y as usize * ww + x as usize] = 0x00ff_5028;
                        }
                    }
                }
            }
        }
        window.pre_present_notify();
        buf.present().map_err(err)?;
        Ok(rect)
    }
}

/// The largest rectangle of a `w` × `h` frame's aspect centred in `avail`.
pub fn fit(avail: egui::Rect, w: u32, h: u32) -> egui::Rect {
    let k = (avail.width() / w.max(1) as f32).min(avail.height() / h.max(1) as f32);
    egui::Rect::from_center_size(avail.center(), egui::vec2(w as f32 * k, h as f32 * k))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_frame_fits_centred_at_its_aspect() {
        let avail = egui::Rect::from_min_size(egui::pos2(100.0, 0.0), egui::vec2(400.0, 100.0));
        let r = fit(avail, 200, 100);
        assert_eq!(
            r,
            egui::Rect::from_min_max(egui::pos2(200.0, 0.0), egui::pos2(400.0, 100.0))
        );
    }
}

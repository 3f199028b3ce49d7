//! The window: winit delivers input, softbuffer presents the viewer's 0RGB frame. Everything
//! else (what to draw, when the picture is final) is the [`Viewer`]'s; this file only maps
//! events to its input and actions and decides whether to keep drawing or sleep until the next
//! event.

use crate::ViewError;
use crate::camera::InputState;
use crate::viewer::{Action, Viewer};
use glint_core::Vec2;
use glint_scene::RenderMode;
use std::num::NonZeroU32;
use std::path::PathBuf;
use std::rc::Rc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{Window, WindowId};

/// How a window session ends on its own (for scripted runs and the window test).
#[derive(Clone, Debug, Default)]
pub struct WindowOptions {
    /// Close after this many frames.
    pub frames: Option<u64>,
    /// On close, read the window's contents back from the display server and write them here
    /// as PNG (what was on screen, statistics included).
    pub capture: Option<PathBuf>,
}

/// What a window session did.
#[derive(Clone, Debug, Default)]
pub struct WindowReport {
    pub frames: u64,
    /// Pixels read back from the window (0RGB) when a capture was asked for, with their size.
    pub captured: Option<(u32, u32)>,
}

/// Open a window on `viewer` and run until it is closed (Esc, the close button, or
/// `options.frames`).
pub fn run(viewer: Viewer, title: &str, options: WindowOptions) -> Result<WindowReport, ViewError> {
    check_display()?;
    let event_loop = EventLoop::new().map_err(|e| ViewError::Window(e.to_string()))?;
    let mut app = App {
        viewer,
        title: title.to_string(),
        options,
        window: None,
        surface: None,
        keys: Keys::default(),
        look: Vec2::ZERO,
        scroll: 0.0,
        dragging: false,
        cursor: None,
        last_frame: None,
        report: WindowReport::default(),
        error: None,
    };
    event_loop.run_app(&mut app).map_err(|e| ViewError::Window(e.to_string()))?;
    match app.error {
        Some(e) => Err(e),
        None => Ok(app.report),
    }
}

/// Refuse at once, with a message that says why, when there is no display to open a window
/// on (winit would otherwise fail deep inside a backend).
fn check_display() -> Result<(), ViewError> {
    #[cfg(all(unix, not(target_os = "macos")))]
    {
        let set = |v: &str| std::env::var_os(v).is_some_and(|s| !s.is_empty());
        if !set("DISPLAY") && !set("WAYLAND_DISPLAY") {
            return Err(ViewError::Window(
                "no display (neither DISPLAY nor WAYLAND_DISPLAY is set); `glint bench view` runs the same frame loop without a window"
                    .into(),
            ));
        }
    }
    Ok(())
}

/// Movement keys held down.
#[derive(Clone, Copy, Debug, Default)]
struct Keys {
    forward: bool,
    back: bool,
    left: bool,
    right: bool,
    up: bool,
    down: bool,
    shift: bool,
}

type Surface = softbuffer::Surface<Rc<Window>, Rc<Window>>;

struct App {
    viewer: Viewer,
    title: String,
    options: WindowOptions,
    window: Option<Rc<Window>>,
    surface: Option<Surface>,
    keys: Keys,
    /// Mouse motion while dragging, and scroll notches, since the last frame.
    look: Vec2,
    scroll: f32,
    dragging: bool,
    cursor: Option<Vec2>,
    last_frame: Option<Instant>,
    report: WindowReport,
    error: Option<ViewError>,
}

/// The action of a key, if it has one.
fn action_for(key: KeyCode) -> Option<Action> {
    Some(match key {
        KeyCode::Digit1 | KeyCode::Numpad1 => Action::Mode(RenderMode::Whitted),
        KeyCode::Digit2 | KeyCode::Numpad2 => Action::Mode(RenderMode::Path),
        KeyCode::Digit3 | KeyCode::Numpad3 => Action::Mode(RenderMode::Points),
        KeyCode::KeyF => Action::CycleFilter,
        KeyCode::Equal | KeyCode::NumpadAdd => Action::MoreSamples,
        KeyCode::Minus | KeyCode::NumpadSubtract => Action::FewerSamples,
        KeyCode::BracketRight => Action::MoreBounces,
        KeyCode::BracketLeft => Action::FewerBounces,
        KeyCode::Period => Action::FinerResolution,
        KeyCode::Comma => Action::CoarserResolution,
        KeyCode::KeyR => Action::ToggleAdaptive,
        KeyCode::KeyV => Action::CycleDisplay,
        KeyCode::KeyC => Action::ToggleCamera,
        KeyCode::Home => Action::ResetCamera,
        KeyCode::Space => Action::ToggleAnimation,
        KeyCode::Tab => Action::ToggleOverlay,
        KeyCode::KeyH | KeyCode::F1 => Action::ToggleHelp,
        KeyCode::KeyP | KeyCode::F12 => Action::Screenshot,
        KeyCode::Escape => Action::Quit,
        _ => return None,
    })
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: ViewError) {
        self.error.get_or_insert(e);
        event_loop.exit();
    }

    fn input(&self) -> InputState {
        let k = self.keys;
        InputState {
            forward: k.forward,
            back: k.back,
            left: k.left,
            right: k.right,
            up: k.up,
            down: k.down,
            fast: k.shift,
            look: self.look,
            scroll: self.scroll,
        }
    }

    /// Frames are needed: input is under way, the picture is refining, or a frame count is
    /// being run out.
    fn busy(&self) -> bool {
        self.options.frames.is_some() || !self.input().is_idle() || !self.viewer.is_idle()
    }

    fn redraw(&mut self, event_loop: &ActiveEventLoop) {
        let now = Instant::now();
        let dt = self.last_frame.map_or(0.0, |t| now.duration_since(t).as_secs_f32());
        self.last_frame = Some(now);
        let input = self.input();
        self.look = Vec2::ZERO;
        self.scroll = 0.0;
        if let Err(e) = self.viewer.frame(&input, dt) {
            return self.fail(event_loop, e);
        }
        let (w, h) = self.viewer.size();
        let Some(surface) = self.surface.as_mut() else { return };
        let (Some(nw), Some(nh)) = (NonZeroU32::new(w), NonZeroU32::new(h)) else { return };
        let presented = surface.resize(nw, nh).and_then(|()| {
            let mut buffer = surface.buffer_mut()?;
            if buffer.len() == self.viewer.pixels().len() {
                buffer.copy_from_slice(self.viewer.pixels());
            }
            buffer.present()
        });
        if let Err(e) = presented {
            return self.fail(event_loop, ViewError::Window(format!("cannot present a frame: {e}")));
        }
        self.report.frames += 1;
        if let Some(n) = self.options.frames
            && self.report.frames >= n
        {
            self.close(event_loop);
        }
    }

    /// Capture the window if asked, then stop the loop.
    fn close(&mut self, event_loop: &ActiveEventLoop) {
        if let (Some(path), Some(surface)) = (self.options.capture.clone(), self.surface.as_mut()) {
            let (w, h) = self.viewer.size();
            match surface.fetch() {
                Ok(pixels) if pixels.len() == w as usize * h as usize => {
                    if let Err(e) = write_capture(&path, &pixels, w, h) {
                        return self.fail(event_loop, e);
                    }
                    self.report.captured = Some((w, h));
                }
                Ok(pixels) => {
                    let e = format!("the window read back {} pixels, not {w}x{h}", pixels.len());
                    return self.fail(event_loop, ViewError::Window(e));
                }
                Err(e) => return self.fail(event_loop, ViewError::Window(format!("cannot read the window back: {e}"))),
            }
        }
        event_loop.exit();
    }
}

/// 0RGB words → an sRGB PNG (the bytes are already display values: written as they are).
fn write_capture(path: &std::path::Path, pixels: &[u32], w: u32, h: u32) -> Result<(), ViewError> {
    let linear = |p: u32, shift: u32| glint_core::colour::srgb_to_linear(((p >> shift) & 0xff) as f32 / 255.0);
    let rgb: Vec<[f32; 3]> = pixels.iter().map(|&p| [linear(p, 16), linear(p, 8), linear(p, 0)]).collect();
    let image = glint_image::Image::from_rgb(w, h, &rgb);
    glint_image::write_png(path, &image, &glint_image::PngOptions::default())
        .map_err(|e| ViewError::Write(path.to_path_buf(), e.to_string()))
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.window.is_some() {
            return;
        }
        let (w, h) = self.viewer.size();
        let attributes = Window::default_attributes()
            .with_title(format!("glint — {}", self.title))
            .with_inner_size(PhysicalSize::new(w, h));
        let window = match event_loop.create_window(attributes) {
            Ok(w) => Rc::new(w),
            Err(e) => return self.fail(event_loop, ViewError::Window(e.to_string())),
        };
        let surface = softbuffer::Context::new(window.clone())
            .and_then(|context| softbuffer::Surface::new(&context, window.clone()));
        match surface {
            Ok(s) => self.surface = Some(s),
            Err(e) => return self.fail(event_loop, ViewError::Window(format!("no pixel buffer for the window: {e}"))),
        }
        // The window manager may not grant the size asked for.
        let size = window.inner_size();
        self.viewer.resize(size.width, size.height);
        window.request_redraw();
        self.window = Some(window);
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => self.close(event_loop),
            WindowEvent::Resized(size) => self.viewer.resize(size.width, size.height),
            WindowEvent::RedrawRequested => self.redraw(event_loop),
            WindowEvent::KeyboardInput { event, .. } => {
                let PhysicalKey::Code(code) = event.physical_key else { return };
                let pressed = event.state == ElementState::Pressed;
                let k = &mut self.keys;
                match code {
                    KeyCode::KeyW | KeyCode::ArrowUp => k.forward = pressed,
                    KeyCode::KeyS | KeyCode::ArrowDown => k.back = pressed,
                    KeyCode::KeyA | KeyCode::ArrowLeft => k.left = pressed,
                    KeyCode::KeyD | KeyCode::ArrowRight => k.right = pressed,
                    KeyCode::KeyE | KeyCode::PageUp => k.up = pressed,
                    KeyCode::KeyQ | KeyCode::PageDown => k.down = pressed,
                    KeyCode::ShiftLeft | KeyCode::ShiftRight => k.shift = pressed,
                    _ if pressed && !event.repeat => {
                        if let Some(action) = action_for(code) {
                            match self.viewer.apply(action) {
                                Ok(true) => {}
                                Ok(false) => self.close(event_loop),
                                Err(e) => self.fail(event_loop, e),
                            }
                        }
                    }
                    _ => {}
                }
            }
            WindowEvent::MouseInput { state, button, .. } => {
                if matches!(button, MouseButton::Left | MouseButton::Right | MouseButton::Middle) {
                    self.dragging = state == ElementState::Pressed;
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                let p = Vec2::new(position.x as f32, position.y as f32);
                if let Some(last) = self.cursor
                    && self.dragging
                {
                    self.look += p - last;
                }
                self.cursor = Some(p);
            }
            WindowEvent::CursorLeft { .. } => self.cursor = None,
            WindowEvent::MouseWheel { delta, .. } => {
                self.scroll += match delta {
                    MouseScrollDelta::LineDelta(_, y) => y,
                    MouseScrollDelta::PixelDelta(p) => p.y as f32 / 40.0,
                };
            }
            WindowEvent::Focused(false) => self.keys = Keys::default(),
            _ => {}
        }
        if self.busy()
            && let Some(w) = &self.window
        {
            w.request_redraw();
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        if self.busy() {
            event_loop.set_control_flow(ControlFlow::Poll);
            if let Some(w) = &self.window {
                w.request_redraw();
            }
        } else {
            // At rest with a final picture: sleep until the next event; the clock restarts so
            // the first frame after it does not jump.
            event_loop.set_control_flow(ControlFlow::Wait);
            self.last_frame = None;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::viewer::KEYS;

    /// Every key the on-screen help lists does what it says, and movement keys are not
    /// actions.
    #[test]
    fn keys_map_to_the_actions_the_help_lists() {
        let expected = [
            (KeyCode::Digit1, Action::Mode(RenderMode::Whitted)),
            (KeyCode::Digit2, Action::Mode(RenderMode::Path)),
            (KeyCode::Digit3, Action::Mode(RenderMode::Points)),
            (KeyCode::KeyF, Action::CycleFilter),
            (KeyCode::Minus, Action::FewerSamples),
            (KeyCode::Equal, Action::MoreSamples),
            (KeyCode::BracketLeft, Action::FewerBounces),
            (KeyCode::BracketRight, Action::MoreBounces),
            (KeyCode::Comma, Action::CoarserResolution),
            (KeyCode::Period, Action::FinerResolution),
            (KeyCode::KeyR, Action::ToggleAdaptive),
            (KeyCode::KeyV, Action::CycleDisplay),
            (KeyCode::KeyC, Action::ToggleCamera),
            (KeyCode::Home, Action::ResetCamera),
            (KeyCode::Space, Action::ToggleAnimation),
            (KeyCode::KeyP, Action::Screenshot),
            (KeyCode::F12, Action::Screenshot),
            (KeyCode::Tab, Action::ToggleOverlay),
            (KeyCode::KeyH, Action::ToggleHelp),
            (KeyCode::Escape, Action::Quit),
        ];
        for (key, action) in expected {
            assert_eq!(action_for(key), Some(action), "{key:?}");
        }
        for key in [KeyCode::KeyW, KeyCode::KeyA, KeyCode::KeyS, KeyCode::KeyD, KeyCode::KeyQ, KeyCode::KeyE] {
            assert_eq!(action_for(key), None, "{key:?} moves the camera");
        }
        // The help names every key above.
        let help: String = KEYS.iter().map(|(k, _)| *k).collect::<Vec<_>>().join(" ");
        for name in ["1 2 3", "F", "- =", "[ ]", ", .", "R", "V", "C", "Home", "Space", "P F12", "Tab", "H", "Esc"] {
            assert!(help.contains(name), "{name} missing from the help");
        }
    }
}

//! What the mouse and the keys do in the window, independent of the window system: the
//! window turns its events into [`Input`]s and [`Controls::handle`] applies them to the
//! [`ViewState`] (camera, layers, cut plane, wireframe, pause, key list). Scripted input
//! (`--script`, see [`parse_script`]) goes through the same function, so tests drive the
//! window's own code path without a mouse.
//!
//! [`BINDINGS`] is the one list of bindings: the in-window key list (`?`) prints it and
//! `viewer/README.md` shows the same table (a test compares them).
//!
//! # Examples
//!
//! ```
//! use glam::Vec3;
//! use lamina_viewer::camera::{Camera, OrbitCamera};
//! use lamina_viewer::controls::{Button, Controls, Input};
//!
//! let start = Camera { eye: Vec3::new(0.0, 0.0, 2.0), target: Vec3::ZERO, up: Vec3::Y, fov_y: 1.0 };
//! let mut controls = Controls::default();
//! controls.state.camera = Some(OrbitCamera::new(start));
//! controls.handle(&Input::Key("w".into()), (640.0, 480.0), 4);
//! assert!(controls.state.wireframe);
//! // A left drag orbits about the target: the distance stays 2 m.
//! for input in [Input::Cursor(100.0, 100.0), Input::Button(Button::Left, true), Input::Cursor(160.0, 90.0)] {
//!     controls.handle(&input, (640.0, 480.0), 4);
//! }
//! let cam = controls.state.camera.unwrap();
//! assert!((cam.distance() - 2.0).abs() < 1e-5 && cam.camera() != start);
//! ```

use crate::camera::OrbitCamera;

/// One binding as listed to the user: the input and what it does.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Binding {
    /// Mouse or key input, e.g. `left drag`, `Esc, Q`.
    pub input: &'static str,
    /// What it does.
    pub action: &'static str,
}

/// Every mouse and key binding of the window, in the order the key list shows them.
pub const BINDINGS: &[Binding] = &[
    Binding { input: "left drag", action: "orbit around the model centre" },
    Binding { input: "right or middle drag, shift + left drag", action: "pan" },
    Binding { input: "wheel", action: "zoom toward or away from the centre" },
    Binding { input: "ctrl + left drag", action: "grab the skin under the cursor and pull it (live core)" },
    Binding { input: "ctrl + shift + left drag", action: "cut the skin along the drag with the scalpel (live core)" },
    Binding { input: "R", action: "reset the view" },
    Binding { input: "1 2 3 4", action: "show or hide layer 1..4 (skin, fat, muscle, bone)" },
    Binding { input: "C", action: "cut plane on or off" },
    Binding { input: "[ ]", action: "move the cut plane back or forward (2 % of the model length)" },
    Binding { input: "W", action: "wireframe (the triangle edges) on or off" },
    Binding { input: "T", action: "volume texture on or off (off: each tissue's flat colour)" },
    Binding { input: "Space", action: "pause or resume the drawing (the core keeps running)" },
    Binding { input: "S", action: "screenshot: a PNG in the output directory (path printed)" },
    Binding { input: "?", action: "show or hide this key list" },
    Binding { input: "Esc, Q", action: "quit" },
];

/// The key list as the window shows it (upper case, the built-in font's best).
pub fn key_list_lines() -> Vec<String> {
    let width = BINDINGS.iter().map(|b| b.input.len()).max().unwrap_or(0);
    let mut lines = vec!["KEYS AND MOUSE".to_string()];
    lines.extend(BINDINGS.iter().map(|b| format!("{:width$}  {}", b.input, b.action).to_uppercase()));
    lines
}

/// Orbit angle per pixel of mouse motion, radians (0.008: 180° per ~390 px).
pub const ORBIT_RAD_PER_PIXEL: f32 = 0.008;
/// Cut plane travel per `[` or `]`, as a fraction of the model's length along the plane's
/// normal (0.02).
pub const CUT_STEP_FRACTION: f32 = 0.02;

/// A mouse button.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Button {
    /// Left button.
    Left,
    /// Right button.
    Right,
    /// Middle button (wheel press).
    Middle,
}

/// One user input, as the window reports it.
#[derive(Debug, Clone, PartialEq)]
pub enum Input {
    /// A key pressed: its character in lower case (`"1"`, `"c"`, `"["`, `"?"`), or `"space"`,
    /// `"escape"`.
    Key(String),
    /// A mouse button pressed (`true`) or released.
    Button(Button, bool),
    /// The cursor moved to `(x, y)`, pixels from the top-left corner.
    Cursor(f32, f32),
    /// The wheel turned by this many notches (positive: away from the user, zoom in).
    Wheel(f32),
    /// Shift and Ctrl are now held (`true`) or not.
    Modifiers {
        /// Shift held.
        shift: bool,
        /// Ctrl held.
        ctrl: bool,
    },
}

/// What the window must do after an input (besides drawing the new view state).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Effect {
    /// Write a screenshot.
    Screenshot,
    /// Close the window.
    Quit,
    /// Ctrl + left button pressed at `(x, y)` pixels: pick a skin node and grasp it.
    GrabStart(f32, f32),
    /// The grasping cursor moved to `(x, y)` pixels.
    GrabMove(f32, f32),
    /// The grasping button was released: let go.
    GrabEnd,
}

/// What the user chose to see. `Default`: initial camera (set when the first frame fixes
/// it), all layers, cut on, plane where the default view puts it, filled, running, no key
/// list.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewState {
    /// The moved camera (`None` until the window has a first view).
    pub camera: Option<OrbitCamera>,
    /// Layers hidden, by index into the model's layers (bit `k`: layer `k + 1`).
    pub hidden_layers: u32,
    /// Whether the cut plane is on.
    pub cut: bool,
    /// Cut plane displacement along its normal, in steps of [`CUT_STEP_FRACTION`].
    pub cut_steps: i32,
    /// Triangle edges instead of filled surfaces.
    pub wireframe: bool,
    /// Drawn frame frozen.
    pub paused: bool,
    /// Key list shown.
    pub help: bool,
    /// The volume texture switched from what the options say (on ↔ off) by the key `T`.
    pub texture_toggled: bool,
}

impl Default for ViewState {
    fn default() -> Self {
        Self {
            camera: None,
            hidden_layers: 0,
            cut: true,
            cut_steps: 0,
            wireframe: false,
            paused: false,
            help: false,
            texture_toggled: false,
        }
    }
}

impl ViewState {
    /// Whether layer `k` (0-based) is hidden.
    pub fn layer_hidden(&self, k: usize) -> bool {
        k < 32 && self.hidden_layers & (1 << k) != 0
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Drag {
    Orbit,
    Pan,
    Grab,
}

/// Turns inputs into view changes; see the module docs.
#[derive(Debug, Clone, Default)]
pub struct Controls {
    /// The current choices.
    pub state: ViewState,
    cursor: Option<(f32, f32)>,
    drag: Option<(Button, Drag)>,
    shift: bool,
    ctrl: bool,
}

impl Controls {
    /// Applies `input` for a `viewport` of (width, height) pixels and a model with `layers`
    /// layers (keys beyond it do nothing); returns what the window must do besides redraw.
    pub fn handle(&mut self, input: &Input, viewport: (f32, f32), layers: usize) -> Option<Effect> {
        match input {
            Input::Key(key) => return self.key(key, layers),
            Input::Modifiers { shift, ctrl } => (self.shift, self.ctrl) = (*shift, *ctrl),
            Input::Button(button, true) => {
                let mode = match button {
                    Button::Left if self.ctrl => Drag::Grab,
                    Button::Left if self.shift => Drag::Pan,
                    Button::Left => Drag::Orbit,
                    Button::Right | Button::Middle => Drag::Pan,
                };
                self.drag = Some((*button, mode));
                if mode == Drag::Grab {
                    let (x, y) = self.cursor.unwrap_or((viewport.0 * 0.5, viewport.1 * 0.5));
                    return Some(Effect::GrabStart(x, y));
                }
            }
            Input::Button(button, false) => {
                if let Some((b, mode)) = self.drag
                    && b == *button
                {
                    self.drag = None;
                    if mode == Drag::Grab {
                        return Some(Effect::GrabEnd);
                    }
                }
            }
            Input::Cursor(x, y) => {
                let last = self.cursor.replace((*x, *y));
                if self.drag.is_some_and(|(_, mode)| mode == Drag::Grab) {
                    return Some(Effect::GrabMove(*x, *y));
                }
                if let (Some((lx, ly)), Some((_, mode)), Some(cam)) = (last, self.drag, self.state.camera.as_mut()) {
                    let (dx, dy) = (x - lx, y - ly);
                    match mode {
                        Drag::Orbit => cam.orbit(-dx * ORBIT_RAD_PER_PIXEL, dy * ORBIT_RAD_PER_PIXEL),
                        Drag::Pan => cam.pan(dx, dy, viewport.1),
                        Drag::Grab => {}
                    }
                }
            }
            Input::Wheel(notches) => {
                if let Some(cam) = self.state.camera.as_mut() {
                    cam.zoom(*notches);
                }
            }
        }
        None
    }

    fn key(&mut self, key: &str, layers: usize) -> Option<Effect> {
        let s = &mut self.state;
        match key {
            "escape" | "q" => return Some(Effect::Quit),
            "s" => return Some(Effect::Screenshot),
            "r" => {
                if let Some(cam) = s.camera.as_mut() {
                    cam.reset();
                }
            }
            "c" => s.cut = !s.cut,
            "[" => s.cut_steps = (s.cut_steps - 1).max(-50),
            "]" => s.cut_steps = (s.cut_steps + 1).min(50),
            "w" => s.wireframe = !s.wireframe,
            "t" => s.texture_toggled = !s.texture_toggled,
            "space" | " " => s.paused = !s.paused,
            "?" => s.help = !s.help,
            _ => {
                if let Some(k) = key.parse::<usize>().ok().filter(|k| (1..=layers.min(9)).contains(k)) {
                    s.hidden_layers ^= 1 << (k - 1);
                }
            }
        }
        None
    }
}

/// One scripted input: `frame` is the number of frames drawn before it applies.
#[derive(Debug, Clone, PartialEq)]
pub struct ScriptStep {
    /// Frames drawn before this step.
    pub frame: u64,
    /// The inputs, in order.
    pub inputs: Vec<Input>,
}

/// Parses `--script`: steps separated by `;`, each `FRAME:key:NAME`, `FRAME:wheel:NOTCHES`,
/// `FRAME:drag:BUTTON:DX:DY` (a whole drag from the viewport's centre, DX, DY pixels), or the
/// parts of a drag spread over frames: `FRAME:down:BUTTON:X:Y`, `FRAME:move:X:Y`,
/// `FRAME:up:BUTTON` (X, Y pixels from the top-left corner). BUTTON: `left`, `right`,
/// `middle`, `shift-left` or `ctrl-left`. Example: `2:key:1;3:drag:left:120:-40;4:wheel:2`.
pub fn parse_script(text: &str, viewport: (f32, f32)) -> Result<Vec<ScriptStep>, ScriptParseError> {
    let mut steps = Vec::new();
    for item in text.split(';').map(str::trim).filter(|s| !s.is_empty()) {
        let parts: Vec<&str> = item.split(':').collect();
        let bad = |why: &str| ScriptParseError { step: item.to_string(), why: why.to_string() };
        let frame = parts[0].parse::<u64>().map_err(|_| bad("expected FRAME:WHAT:…, FRAME a whole number"))?;
        let number = |s: &str| s.parse::<f32>().ok().filter(|v| v.is_finite()).ok_or_else(|| bad("not a number"));
        let inputs = match parts.get(1..).unwrap_or_default() {
            ["key", name] if !name.is_empty() => vec![Input::Key(name.to_ascii_lowercase())],
            ["wheel", n] => vec![Input::Wheel(number(n)?)],
            ["drag", button, dx, dy] => {
                let (button, modifiers) = script_button(button).ok_or_else(|| bad(BUTTONS))?;
                let (cx, cy) = (viewport.0 * 0.5, viewport.1 * 0.5);
                vec![
                    modifiers,
                    Input::Cursor(cx, cy),
                    Input::Button(button, true),
                    Input::Cursor(cx + number(dx)?, cy + number(dy)?),
                    Input::Button(button, false),
                    Input::Modifiers { shift: false, ctrl: false },
                ]
            }
            ["down", button, x, y] => {
                let (button, modifiers) = script_button(button).ok_or_else(|| bad(BUTTONS))?;
                vec![modifiers, Input::Cursor(number(x)?, number(y)?), Input::Button(button, true)]
            }
            ["move", x, y] => vec![Input::Cursor(number(x)?, number(y)?)],
            ["up", button] => {
                let (button, _) = script_button(button).ok_or_else(|| bad(BUTTONS))?;
                vec![Input::Button(button, false), Input::Modifiers { shift: false, ctrl: false }]
            }
            _ => {
                return Err(bad(
                    "expected FRAME:key:NAME, FRAME:wheel:N, FRAME:drag:BUTTON:DX:DY, FRAME:down:BUTTON:X:Y, \
                     FRAME:move:X:Y or FRAME:up:BUTTON",
                ));
            }
        };
        steps.push(ScriptStep { frame, inputs });
    }
    steps.sort_by_key(|s| s.frame);
    Ok(steps)
}

/// A `--script` step that does not parse.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("script step '{step}': {why}")]
pub struct ScriptParseError {
    /// The step as written.
    pub step: String,
    /// What is wrong with it.
    pub why: String,
}

const BUTTONS: &str = "button must be left, right, middle, shift-left or ctrl-left";

/// A script's button name: the button and the modifiers held with it.
fn script_button(name: &str) -> Option<(Button, Input)> {
    let (button, shift, ctrl) = match name {
        "left" => (Button::Left, false, false),
        "right" => (Button::Right, false, false),
        "middle" => (Button::Middle, false, false),
        "shift-left" => (Button::Left, true, false),
        "ctrl-left" => (Button::Left, false, true),
        _ => return None,
    };
    Some((button, Input::Modifiers { shift, ctrl }))
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::camera::Camera;

    fn controls() -> Controls {
        let start = Camera {
            eye: Vec3::new(0.0, 0.0, 2.0),
            target: Vec3::ZERO,
            up: Vec3::Y,
            fov_y: core::f32::consts::FRAC_PI_2,
        };
        let mut c = Controls::default();
        c.state.camera = Some(OrbitCamera::new(start));
        c
    }

    fn feed(c: &mut Controls, inputs: &[Input]) -> Vec<Effect> {
        inputs.iter().filter_map(|i| c.handle(i, (100.0, 100.0), 4)).collect()
    }

    fn eye(c: &Controls) -> Vec3 {
        c.state.camera.unwrap().camera().eye
    }

    #[test]
    fn left_drag_orbits_by_the_stated_angle_works() {
        let mut c = controls();
        // 100 px to the left: yaw +0.8 rad, eye at (2 sin 0.8, 0, 2 cos 0.8).
        feed(&mut c, &[Input::Cursor(150.0, 50.0), Input::Button(Button::Left, true), Input::Cursor(50.0, 50.0)]);
        let expected = Vec3::new(2.0 * 0.8f32.sin(), 0.0, 2.0 * 0.8f32.cos());
        assert!((eye(&c) - expected).length() < 1e-5, "{:?}", eye(&c));
        // Released: further motion does nothing.
        feed(&mut c, &[Input::Button(Button::Left, false), Input::Cursor(0.0, 0.0)]);
        assert!((eye(&c) - expected).length() < 1e-5);
    }

    #[test]
    fn right_middle_and_shift_left_drags_pan_works() {
        // 100 px viewport, 90° field of view at 2 m: 0.04 m per pixel; 10 px right moves the
        // camera 0.4 m left.
        for (button, shift) in [(Button::Right, false), (Button::Middle, false), (Button::Left, true)] {
            let mut c = controls();
            feed(
                &mut c,
                &[
                    Input::Modifiers { shift, ctrl: false },
                    Input::Cursor(50.0, 50.0),
                    Input::Button(button, true),
                    Input::Cursor(60.0, 50.0),
                ],
            );
            let cam = c.state.camera.unwrap().camera();
            assert!((cam.target - Vec3::new(-0.4, 0.0, 0.0)).length() < 1e-5, "{button:?} shift {shift}");
            assert!((cam.eye - Vec3::new(-0.4, 0.0, 2.0)).length() < 1e-5);
        }
    }

    #[test]
    fn ctrl_left_drag_grabs_without_moving_the_camera_works() {
        let mut c = controls();
        let effects = feed(
            &mut c,
            &[
                Input::Cursor(30.0, 40.0),
                Input::Modifiers { shift: false, ctrl: true },
                Input::Button(Button::Left, true),
                Input::Cursor(35.0, 20.0),
                Input::Button(Button::Left, false),
            ],
        );
        assert_eq!(effects, [Effect::GrabStart(30.0, 40.0), Effect::GrabMove(35.0, 20.0), Effect::GrabEnd]);
        assert_eq!(eye(&c), Vec3::new(0.0, 0.0, 2.0));
    }

    #[test]
    fn wheel_zooms_and_r_resets_works() {
        let mut c = controls();
        feed(&mut c, &[Input::Wheel(2.0)]);
        assert!((c.state.camera.unwrap().distance() - 2.0 * 0.81).abs() < 1e-5);
        feed(&mut c, &[Input::Key("r".into())]);
        assert_eq!(eye(&c), Vec3::new(0.0, 0.0, 2.0));
    }

    #[test]
    fn keys_toggle_what_the_table_says_works() {
        let mut c = controls();
        assert_eq!(feed(&mut c, &[Input::Key("s".into())]), [Effect::Screenshot]);
        assert_eq!(feed(&mut c, &[Input::Key("escape".into())]), [Effect::Quit]);
        assert_eq!(feed(&mut c, &[Input::Key("q".into())]), [Effect::Quit]);
        feed(&mut c, &[Input::Key("2".into()), Input::Key("4".into()), Input::Key("5".into())]);
        assert_eq!(c.state.hidden_layers, 0b1010, "layers 2 and 4 hidden, no layer 5");
        assert!(c.state.layer_hidden(1) && !c.state.layer_hidden(0));
        feed(&mut c, &[Input::Key("c".into()), Input::Key("w".into()), Input::Key("space".into())]);
        assert!(!c.state.cut && c.state.wireframe && c.state.paused);
        feed(&mut c, &[Input::Key("]".into()), Input::Key("]".into()), Input::Key("[".into())]);
        assert_eq!(c.state.cut_steps, 1);
        feed(&mut c, &[Input::Key("?".into())]);
        assert!(c.state.help);
        feed(&mut c, &[Input::Key("t".into())]);
        assert!(c.state.texture_toggled);
    }

    #[test]
    fn every_binding_is_drawable_works() {
        for line in key_list_lines() {
            assert!(line.chars().all(crate::overlay::has_glyph), "no glyph in '{line}'");
        }
    }

    #[test]
    fn readme_lists_the_same_bindings_works() {
        let readme = include_str!("../README.md");
        let rows: Vec<(String, String)> = readme
            .lines()
            .skip_while(|l| !l.starts_with("| input | action |"))
            .skip(2)
            .take_while(|l| l.starts_with('|'))
            .map(|l| {
                let cells: Vec<&str> = l.trim_matches('|').split(" | ").map(|c| c.trim().trim_matches('`')).collect();
                (cells[0].to_string(), cells.get(1).copied().unwrap_or_default().to_string())
            })
            .collect();
        let expected: Vec<(String, String)> =
            BINDINGS.iter().map(|b| (b.input.to_string(), b.action.to_string())).collect();
        assert_eq!(rows, expected, "viewer/README.md's key table differs from controls::BINDINGS");
    }

    #[test]
    fn script_parses_and_rejects_bad_steps_works() {
        let steps = parse_script("3:drag:left:120:-40; 2:key:1;4:wheel:2", (200.0, 100.0)).unwrap();
        assert_eq!(steps.iter().map(|s| s.frame).collect::<Vec<_>>(), [2, 3, 4]);
        assert_eq!(steps[0].inputs, [Input::Key("1".into())]);
        assert!(steps[1].inputs.contains(&Input::Cursor(220.0, 10.0)));
        let grab = parse_script("1:down:ctrl-left:10:20;2:move:15:25;3:up:ctrl-left", (1.0, 1.0)).unwrap();
        assert_eq!(
            grab[0].inputs,
            [
                Input::Modifiers { shift: false, ctrl: true },
                Input::Cursor(10.0, 20.0),
                Input::Button(Button::Left, true)
            ]
        );
        assert_eq!(grab[1].inputs, [Input::Cursor(15.0, 25.0)]);
        assert_eq!(grab[2].inputs[0], Input::Button(Button::Left, false));
        for bad in ["x:key:1", "1:drag:left:1", "1:drag:side:1:1", "1:wheel:nan", "1:jump", "1:down:left:1", "1:up:x"] {
            assert!(parse_script(bad, (1.0, 1.0)).is_err(), "{bad}");
        }
    }
}

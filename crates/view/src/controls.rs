//! The window's controls: one table, [`CONTROLS`], of every key and mouse input the window
//! handles and what it does. The window's key handler looks keys up in it, and the help of
//! `sightline view --help` and the HUD's help lines are printed from it ([`help_lines`]), so
//! the three cannot drift apart.

use winit::keyboard::KeyCode;

use crate::viewer::Method;

/// A direction of the fly camera, moved in while its key is held.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Along the view direction.
    Forward,
    /// Against the view direction.
    Back,
    /// To the left.
    Left,
    /// To the right.
    Right,
    /// Along the scene's up axis.
    Up,
    /// Against the scene's up axis.
    Down,
}

/// What an input does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Action {
    /// Move while the key is held.
    Move(Direction),
    /// Switch to a visibility method.
    Method(Method),
    /// Toggle x-ray (culled triangles shown tinted red instead of hidden).
    ToggleXray,
    /// Toggle the magenta marks of popping pixels.
    TogglePopping,
    /// Toggle the view-cell wireframe.
    ToggleCells,
    /// Freeze culling at the current camera and fly out, or unfreeze.
    ToggleFreeze,
    /// Pick the next (`true`) or previous view cell for the pvs method.
    StepCell(bool),
    /// Go back to the eye's cell (drop the picked one).
    EyeCell,
    /// Toggle the top-down overview.
    ToggleOverview,
    /// Toggle the HUD's help lines.
    ToggleHelp,
    /// Close the window.
    Quit,
    /// Look around (mouse drag; no key).
    Look,
    /// Change the fly speed (mouse wheel; no key).
    Speed,
}

/// One input of the window: how it is written for people, what it does, and the keys that
/// trigger it (none for the mouse).
#[derive(Clone, Copy, Debug)]
pub struct Control {
    /// The input as printed: `W`, `1`, `H or F1`, `mouse wheel`.
    pub input: &'static str,
    /// What it does, in a few words.
    pub does: &'static str,
    /// The action the window takes.
    pub action: Action,
    /// The physical keys (US layout positions) that trigger it; empty for mouse inputs.
    pub keys: &'static [KeyCode],
}

const fn key(
    input: &'static str,
    does: &'static str,
    action: Action,
    keys: &'static [KeyCode],
) -> Control {
    Control {
        input,
        does,
        action,
        keys,
    }
}

/// Every input the window handles, in the order help lists them. Method keys follow
/// [`Method::ALL`] (key 1 is the first; a unit test checks the two agree).
pub const CONTROLS: &[Control] = &[
    key(
        "W",
        "move forward",
        Action::Move(Direction::Forward),
        &[KeyCode::KeyW],
    ),
    key(
        "S",
        "move back",
        Action::Move(Direction::Back),
        &[KeyCode::KeyS],
    ),
    key(
        "A",
        "move left",
        Action::Move(Direction::Left),
        &[KeyCode::KeyA],
    ),
    key(
        "D",
        "move right",
        Action::Move(Direction::Right),
        &[KeyCode::KeyD],
    ),
    key(
        "E",
        "move up",
        Action::Move(Direction::Up),
        &[KeyCode::KeyE],
    ),
    key(
        "Q",
        "move down",
        Action::Move(Direction::Down),
        &[KeyCode::KeyQ],
    ),
    key(
        "drag",
        "look around (right or left button)",
        Action::Look,
        &[],
    ),
    key("wheel", "fly faster or slower", Action::Speed, &[]),
    key(
        "1",
        "method none: draw everything",
        Action::Method(Method::None),
        &[KeyCode::Digit1],
    ),
    key(
        "2",
        "method pvs: the eye's cell",
        Action::Method(Method::Pvs),
        &[KeyCode::Digit2],
    ),
    key(
        "3",
        "method occlusion: chunk culling",
        Action::Method(Method::Occlusion),
        &[KeyCode::Digit3],
    ),
    key(
        "4",
        "method exact: analytic set",
        Action::Method(Method::Exact),
        &[KeyCode::Digit4],
    ),
    key(
        "X",
        "x-ray: show culled in red",
        Action::ToggleXray,
        &[KeyCode::KeyX],
    ),
    key(
        "P",
        "popping marks (magenta)",
        Action::TogglePopping,
        &[KeyCode::KeyP],
    ),
    key(
        "C",
        "view-cell wireframe",
        Action::ToggleCells,
        &[KeyCode::KeyC],
    ),
    key(
        "F",
        "freeze culling, fly out",
        Action::ToggleFreeze,
        &[KeyCode::KeyF],
    ),
    key(
        "]",
        "pick next cell for pvs",
        Action::StepCell(true),
        &[KeyCode::BracketRight],
    ),
    key(
        "[",
        "pick previous cell",
        Action::StepCell(false),
        &[KeyCode::BracketLeft],
    ),
    key(
        "Backspace",
        "back to the eye's cell",
        Action::EyeCell,
        &[KeyCode::Backspace],
    ),
    key(
        "O",
        "top-down overview",
        Action::ToggleOverview,
        &[KeyCode::KeyO],
    ),
    key(
        "H, F1",
        "this help",
        Action::ToggleHelp,
        &[KeyCode::KeyH, KeyCode::F1],
    ),
    key("Esc", "quit", Action::Quit, &[KeyCode::Escape]),
];

/// The action of physical key `code`, if the window handles it.
pub fn action_of(code: KeyCode) -> Option<Action> {
    CONTROLS
        .iter()
        .find(|c| c.keys.contains(&code))
        .map(|c| c.action)
}

/// The controls as aligned lines, `input  does`, one per control (for `--help` and the HUD).
pub fn help_lines() -> Vec<String> {
    let width = CONTROLS.iter().map(|c| c.input.len()).max().unwrap_or(0);
    CONTROLS
        .iter()
        .map(|c| format!("{:width$}  {}", c.input, c.does))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_key_triggers_two_controls() {
        let mut keys: Vec<KeyCode> = CONTROLS
            .iter()
            .flat_map(|c| c.keys.iter().copied())
            .collect();
        let n = keys.len();
        keys.sort_by_key(|k| format!("{k:?}"));
        keys.dedup();
        assert_eq!(keys.len(), n);
    }

    #[test]
    fn method_keys_agree_with_method_key_numbers() {
        for m in Method::ALL {
            let c = CONTROLS
                .iter()
                .find(|c| c.action == Action::Method(m))
                .unwrap_or_else(|| panic!("no key for method {}", m.name()));
            assert_eq!(c.input, m.key().to_string());
            assert!(c.does.contains(m.name()), "{}", c.does);
        }
    }

    #[test]
    fn help_has_one_line_per_control_naming_its_input() {
        let lines = help_lines();
        assert_eq!(lines.len(), CONTROLS.len());
        for (line, c) in lines.iter().zip(CONTROLS) {
            assert!(
                line.starts_with(c.input) && line.ends_with(c.does),
                "{line}"
            );
        }
    }

    #[test]
    fn unhandled_key_has_no_action() {
        assert_eq!(action_of(KeyCode::KeyZ), None);
        assert_eq!(action_of(KeyCode::F1), Some(Action::ToggleHelp));
    }

    #[test]
    fn freeze_cell_and_overview_keys_are_listed() {
        assert_eq!(action_of(KeyCode::KeyF), Some(Action::ToggleFreeze));
        assert_eq!(
            action_of(KeyCode::BracketRight),
            Some(Action::StepCell(true))
        );
        assert_eq!(
            action_of(KeyCode::BracketLeft),
            Some(Action::StepCell(false))
        );
        assert_eq!(action_of(KeyCode::Backspace), Some(Action::EyeCell));
        assert_eq!(action_of(KeyCode::KeyO), Some(Action::ToggleOverview));
        let lines = help_lines();
        for input in ["F ", "] ", "[ ", "Backspace ", "O "] {
            assert!(lines.iter().any(|l| l.starts_with(input)), "{input}");
        }
    }
}

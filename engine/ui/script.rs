//! Scripted UI sessions (`--ui-script`): clicks on named widgets and actions at given frames,
//! so an interactive session can be replayed — by tests under Xvfb, or to make screenshots.

use std::path::PathBuf;

/// Something a script does.
#[derive(Clone, Debug, PartialEq)]
pub enum Action {
    /// Left-click the widget tracked under this name.
    Click(String),
    /// Press the middle of the widget tracked under this name and release a frame later (moves
    /// a slider to its middle).
    Press(String),
    /// The Screenshot button: the scene without the UI, as PNG and EXR.
    Screenshot,
    /// Save the window (scene and UI) as a PNG.
    Capture(PathBuf),
    /// The Save scene button.
    SaveScene,
    /// Ask for a new inner window size in pixels (the window system may refuse).
    Resize(u32, u32),
    /// Minimize (true) or restore (false) the window (without a window manager, as under a bare
    /// Xvfb, nothing happens).
    Minimize(bool),
    /// Close the window.
    Quit,
}

/// A script: actions at presented-frame numbers, in order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Script {
    steps: Vec<(u64, Action)>,
}

impl Script {
    /// Parses `FRAME:ACTION;FRAME:ACTION…` with actions `click=NAME`, `press=NAME`, `screenshot`,
    /// `capture=PATH`, `save-scene`, `resize=WxH`, `minimize`, `restore`, `quit`.
    pub fn parse(text: &str) -> Result<Self, String> {
        let mut steps = Vec::new();
        for item in text.split(';').map(str::trim).filter(|s| !s.is_empty()) {
            let (frame, action) =
                item.split_once(':').ok_or_else(|| format!("ui script `{item}`: expected FRAME:ACTION"))?;
            let frame: u64 =
                frame.trim().parse().map_err(|_| format!("ui script `{item}`: `{frame}` is not a frame number"))?;
            let action = match action.trim().split_once('=') {
                Some(("click", name)) if !name.is_empty() => Action::Click(name.to_string()),
                Some(("press", name)) if !name.is_empty() => Action::Press(name.to_string()),
                Some(("capture", path)) if !path.is_empty() => Action::Capture(path.into()),
                None if action.trim() == "screenshot" => Action::Screenshot,
                None if action.trim() == "save-scene" => Action::SaveScene,
                Some(("resize", size)) => {
                    let wh = size.split_once('x').and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)));
                    match wh {
                        Some((w, h)) if (1..=16384).contains(&w) && (1..=16384).contains(&h) => Action::Resize(w, h),
                        _ => return Err(format!("ui script `{item}`: expected resize=WxH, 1..=16384 each")),
                    }
                }
                None if action.trim() == "minimize" => Action::Minimize(true),
                None if action.trim() == "restore" => Action::Minimize(false),
                None if action.trim() == "quit" => Action::Quit,
                _ => {
                    return Err(format!(
                        "ui script `{item}`: unknown action (click=NAME, press=NAME, screenshot, capture=PATH, save-scene, resize=WxH, minimize, restore, quit)"
                    ))
                }
            };
            steps.push((frame, action));
        }
        if steps.windows(2).any(|w| w[1].0 < w[0].0) {
            return Err("ui script: frame numbers must not decrease".into());
        }
        Ok(Self { steps })
    }

    /// The actions due at `frame`.
    pub fn at(&self, frame: u64) -> impl Iterator<Item = &Action> {
        self.steps.iter().filter(move |(f, _)| *f == frame).map(|(_, a)| a)
    }

    /// The frame of the first `quit`, which ends the run.
    pub fn quit_frame(&self) -> Option<u64> {
        self.steps.iter().find(|(_, a)| *a == Action::Quit).map(|(f, _)| *f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_and_rejects() {
        let s = Script::parse(
            "2:click=renderer:mip; 5:screenshot;6:capture=a.png;7:resize=64x48;8:minimize;8:restore;9:quit",
        )
        .expect("valid");
        assert_eq!(s.at(7).collect::<Vec<_>>(), vec![&Action::Resize(64, 48)]);
        assert_eq!(s.at(8).collect::<Vec<_>>(), vec![&Action::Minimize(true), &Action::Minimize(false)]);
        assert_eq!(s.at(2).collect::<Vec<_>>(), vec![&Action::Click("renderer:mip".into())]);
        assert_eq!(s.at(5).collect::<Vec<_>>(), vec![&Action::Screenshot]);
        assert_eq!(s.quit_frame(), Some(9));
        assert_eq!(s.at(3).count(), 0);
        let p = Script::parse("4:press=segment-opacity:1").expect("valid");
        assert_eq!(p.at(4).collect::<Vec<_>>(), vec![&Action::Press("segment-opacity:1".into())]);
        for bad in ["x:quit", "3", "3:jump", "3:click=", "3:press=", "5:quit;2:quit", "3:resize=0x4", "3:resize=64"] {
            assert!(Script::parse(bad).is_err(), "{bad} accepted");
        }
    }
}

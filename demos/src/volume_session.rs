//! Volume session files (`volume --scene FILE.toml`): what the window's "Save scene" writes, so
//! an interactive session replays headless. Values from the command line win over the file's.

use crate::cli::DemoArgs;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use vkengine::settings::{self, Origin, Setting};
use vkengine::{Error, Result};

/// The file's contents.
#[derive(Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct VolumeSession {
    /// Renderer name (`--renderer`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub renderer: Option<String>,
    /// Volume file (`--volume`), relative to the session file; absent for procedural scenes.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub volume: Option<PathBuf>,
    /// Raw volumes: `X,Y,Z`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub dims: Option<[u32; 3]>,
    /// Raw volumes: voxel type.
    #[serde(skip_serializing_if = "Option::is_none", rename = "type")]
    pub voxel_type: Option<String>,
    /// Raw volumes: endianness.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub endian: Option<String>,
    /// Voxel spacing.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spacing: Option<[f32; 3]>,
    /// DICOM series UID (`--series`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub series: Option<String>,
    /// NIfTI 4D volume index (`--frame`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub frame: Option<u32>,
    /// OpenVDB grid name (`--grid`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub grid: Option<String>,
    /// `--set` keys and values (TOML strings, numbers or booleans).
    #[serde(default, deserialize_with = "scalars")]
    pub settings: BTreeMap<String, String>,
}

/// Reads `[settings]` values written as strings, numbers or booleans as the text `--set` takes.
fn scalars<'de, D: serde::Deserializer<'de>>(d: D) -> std::result::Result<BTreeMap<String, String>, D::Error> {
    let raw = BTreeMap::<String, toml::Value>::deserialize(d)?;
    raw.into_iter()
        .map(|(k, v)| match vkengine::settings::toml_text(&v) {
            Some(t) => Ok((k, t)),
            None => Err(serde::de::Error::custom(format!("settings.{k}: must be a string, number or boolean"))),
        })
        .collect()
}

impl VolumeSession {
    /// Reads a session file.
    pub fn load(path: &Path) -> Result<Self> {
        let text =
            std::fs::read_to_string(path).map_err(|source| Error::Io { path: path.display().to_string(), source })?;
        toml::from_str(&text).map_err(|e| Error::Input(format!("{}: not a volume session: {e}", path.display())))
    }

    /// Writes it, with a header saying how to replay it.
    pub fn save(&self, path: &Path) -> Result<()> {
        let body = toml::to_string(self).map_err(|e| Error::Input(e.to_string()))?;
        let text = format!("# vkengine volume session — replay with: volume --scene {}\n{body}", path.display());
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|source| Error::Io { path: dir.display().to_string(), source })?;
        }
        std::fs::write(path, text).map_err(|source| Error::Io { path: path.display().to_string(), source })
    }

    /// `args` with the session at `--scene` filled in under the command line's own values.
    pub fn apply(args: &DemoArgs) -> Result<DemoArgs> {
        let Some(path) = &args.scene else { return Ok(args.clone()) };
        let file = Self::load(path)?;
        // Checked here, while it is known which file a value came from; merged below into
        // `--set`, where the command line's own values follow and win.
        let origin = Origin::File(path.display().to_string());
        let mut own = settings::tagged(&file.settings, &origin);
        own.extend(file.renderer.iter().map(|r| Setting::new("renderer", r.clone(), origin.clone())));
        vkengine::volume::render::settings::SCHEMA
            .apply(&mut vkengine::volume::render::settings::VolumeSetup::default(), &own)?;
        let base = path.parent().unwrap_or(Path::new(""));
        let rel = |p: PathBuf| if p.is_absolute() { p } else { base.join(p) };
        let mut out = args.clone();
        out.renderer = args.renderer.clone().or(file.renderer);
        out.volume = args.volume.clone().or(file.volume.map(rel));
        out.dims = args.dims.or(file.dims);
        out.voxel_type = args.voxel_type.clone().or(file.voxel_type);
        out.endian = args.endian.clone().or(file.endian);
        out.spacing = args.spacing.or(file.spacing);
        out.series = args.series.clone().or(file.series);
        out.frame = args.frame.or(file.frame);
        out.grid = args.grid.clone().or(file.grid);
        let mut sets: Vec<(String, String)> = file
            .settings
            .into_iter()
            .map(|(k, v)| {
                // Paths in settings (tf, env_map) are relative to the session file too.
                let path_like = (k == "tf" && v.ends_with(".json")) || (k == "env_map" && v != "sky");
                let v = if path_like { rel(PathBuf::from(&v)).display().to_string() } else { v };
                (k, v)
            })
            .collect();
        sets.extend(args.set.iter().cloned());
        out.set = sets;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[test]
    fn session_fills_in_under_the_command_line_and_names_bad_files() {
        let dir = std::env::temp_dir().join(format!("vkengine-session-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("dir");
        let path = dir.join("s.toml");
        let s = VolumeSession {
            renderer: Some("mcs".into()),
            settings: [("tf", "s-tf.json"), ("g", "0.5"), ("exposure", "2")]
                .iter()
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
            ..Default::default()
        };
        s.save(&path).expect("save");
        assert_eq!(VolumeSession::load(&path).expect("load"), s);
        let cli = DemoArgs::parse_from(["volume", "--scene", path.to_str().expect("utf-8"), "--set", "g=0.1"]);
        let args = VolumeSession::apply(&cli).expect("apply");
        assert_eq!(args.renderer.as_deref(), Some("mcs"));
        // The command line's g comes last, so it wins; the TF path is relative to the file.
        assert_eq!(crate::cli::setting::<f32>(&args.set, "g").expect("g"), Some(0.1));
        let tf: Option<String> = crate::cli::setting(&args.set, "tf").expect("tf");
        assert_eq!(tf.map(PathBuf::from), Some(dir.join("s-tf.json")));
        // Booleans and numbers are settings too; a bad value names the file and the key.
        std::fs::write(&path, "[settings]\ness = false\ng = 0.25\n").expect("write");
        let args = VolumeSession::apply(&cli).expect("bool and number settings");
        assert!(!crate::volume_scene::volume_setup(&args).expect("parse").render.empty_space_skipping);
        std::fs::write(&path, "[settings]\ness = \"maybe\"\n").expect("write");
        let e = VolumeSession::apply(&cli).expect_err("bad bool").to_string();
        assert!(e.contains("s.toml: settings.ess=maybe"), "{e}");
        std::fs::write(&path, "renderer = \"mcs\"\nbogus = 1\n").expect("write");
        let e = VolumeSession::load(&path).expect_err("unknown key").to_string();
        assert!(e.contains("s.toml") && e.contains("bogus"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }
}

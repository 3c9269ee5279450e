//! Reading scene files (TOML or JSON) with `--set` overrides, into a checked [`Scene`].

use super::{Scene, SceneError};
use std::path::Path;

/// Read, override and check a scene file.
pub fn load_scene(path: &Path) -> Result<Scene, SceneError> {
    load_scene_with_overrides(path, &[])
}

/// Read a scene file, apply `key.path=value` overrides (values parsed as TOML: numbers, booleans,
/// strings), then check it.
pub fn load_scene_with_overrides(path: &Path, overrides: &[String]) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| SceneError::new(&file, "(file)", format!("cannot read: {e}")))?;
    let is_json = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let base_dir = path.parent().map(|p| p.to_path_buf()).unwrap_or_default();
    check_scene_str(&text, is_json, &file, overrides, &base_dir)
}

/// Parse scene text, apply overrides and run every check, as [`load_scene_with_overrides`]
/// does for a file; record files are read relative to `base_dir`.
pub fn check_scene_str(
    text: &str,
    is_json: bool,
    file: &str,
    overrides: &[String],
    base_dir: &Path,
) -> Result<Scene, SceneError> {
    let mut scene = parse_scene_str(text, is_json, file, overrides)?;
    scene.base_dir = base_dir.to_path_buf();
    scene.source = file.to_string();
    super::validate::validate(&scene)?;
    Ok(scene)
}

/// Parse scene text (no validation beyond the format). `file` names the source in messages.
pub fn parse_scene_str(
    text: &str,
    is_json: bool,
    file: &str,
    overrides: &[String],
) -> Result<Scene, SceneError> {
    if text.trim().is_empty() {
        return Err(SceneError::new(file, "(file)", "the file is empty"));
    }
    let mut value: serde_json::Value = if is_json {
        serde_json::from_str(text).map_err(|e| {
            SceneError::new(
                file,
                format!("line {}", e.line()),
                format!("invalid JSON: {e}"),
            )
        })?
    } else {
        let table: toml::Table =
            toml::from_str(text).map_err(|e| toml_syntax_error(file, text, &e))?;
        reject_non_finite(&toml::Value::Table(table.clone()), String::new(), file)?;
        serde_json::to_value(table).map_err(|e| SceneError::new(file, "(file)", e.to_string()))?
    };
    if !value.is_object() {
        let kind = match &value {
            serde_json::Value::Array(_) => "an array",
            serde_json::Value::String(_) => "a string",
            serde_json::Value::Number(_) => "a number",
            serde_json::Value::Bool(_) => "a boolean",
            _ => "null",
        };
        return Err(SceneError::new(
            file,
            "(top level)",
            format!("a scene must be a table of fields, not {kind}"),
        ));
    }
    for o in overrides {
        apply_override(&mut value, o).map_err(|m| SceneError::new(file, "--set", m))?;
    }
    let mut scene: Scene = serde_path_to_error::deserialize(&value).map_err(|e| {
        let path = e.path().to_string();
        let field = if path == "." {
            "(top level)".to_string()
        } else {
            path
        };
        SceneError::new(file, field, clean_serde_message(&e.inner().to_string()))
    })?;
    scene.source = file.to_string();
    Ok(scene)
}

fn toml_syntax_error(file: &str, text: &str, e: &toml::de::Error) -> SceneError {
    let line = e
        .span()
        .map(|s| text[..s.start.min(text.len())].lines().count().max(1))
        .map(|l| format!("line {l}"))
        .unwrap_or_else(|| "(file)".to_string());
    SceneError::new(
        file,
        line,
        format!("invalid TOML: {}", e.message().replace('\n', " ")),
    )
}

/// JSON has no NaN or infinity, so they are caught here while the TOML tree still has them.
fn reject_non_finite(v: &toml::Value, path: String, file: &str) -> Result<(), SceneError> {
    match v {
        toml::Value::Float(f) if !f.is_finite() => Err(SceneError::new(
            file,
            path,
            format!("must be a finite number (got {})", super::num(*f)),
        )),
        toml::Value::Table(t) => {
            for (k, x) in t {
                let p = if path.is_empty() {
                    k.clone()
                } else {
                    format!("{path}.{k}")
                };
                reject_non_finite(x, p, file)?;
            }
            Ok(())
        }
        toml::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                reject_non_finite(x, format!("{path}[{i}]"), file)?;
            }
            Ok(())
        }
        _ => Ok(()),
    }
}

/// A deserialisation message; a wrong type where a number belongs is said
/// plainly (scene values are bare numbers in SI units: `duration = 5`, never `"5 s"`).
fn clean_serde_message(m: &str) -> String {
    // Deserialisation runs on a JSON tree, so messages are single lines; a newline can only
    // come from a quoted key or value, which `SceneError::new` escapes.
    let m = m.trim();
    if let Some(got) = m
        .strip_prefix("invalid type: ")
        .and_then(|rest| rest.strip_suffix(", expected f64"))
    {
        return format!("expected a number in SI units without a unit suffix, got {got}");
    }
    m.to_string()
}

/// Set `a.b.c=value` in a JSON tree; the value is parsed as a TOML value when it can be,
/// otherwise taken as a string.
pub fn apply_override(root: &mut serde_json::Value, assignment: &str) -> Result<(), String> {
    let (key, raw) = assignment
        .split_once('=')
        .ok_or_else(|| format!("`{assignment}` is not of the form key.path=value"))?;
    let key = key.trim();
    if key.is_empty() {
        return Err(format!("`{assignment}` has an empty key"));
    }
    let parsed: serde_json::Value =
        match toml::from_str::<toml::Table>(&format!("v = {}", raw.trim())) {
            Ok(t) => serde_json::to_value(&t["v"]).map_err(|e| e.to_string())?,
            Err(_) => serde_json::Value::String(raw.trim().to_string()),
        };
    let mut node = root;
    let parts: Vec<&str> = key.split('.').collect();
    for (k, part) in parts.iter().enumerate() {
        if part.is_empty() {
            return Err(format!("`{key}` has an empty component"));
        }
        let obj = node
            .as_object_mut()
            .ok_or_else(|| format!("`{key}`: `{}` is not a table", parts[..k].join(".")))?;
        if k + 1 == parts.len() {
            obj.insert(part.to_string(), parsed);
            return Ok(());
        }
        node = obj
            .entry(part.to_string())
            .or_insert_with(|| serde_json::Value::Object(Default::default()));
    }
    Ok(())
}

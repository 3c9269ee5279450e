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
    load_scene_checked(path, overrides, None)
}

/// [`load_scene_with_overrides`], with `tables` checking the engine tables (after the scene's
/// fields, before the run-size checks): what `crate::engines::registry` supplies.
pub fn load_scene_checked(
    path: &Path,
    overrides: &[String],
    tables: Option<super::TableCheck>,
) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let text = crate::input_file::read_to_string(path)
        .map_err(|e| SceneError::new(&file, "(file)", format!("cannot read: {e}")))?;
    let is_json = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"));
    let base_dir = path.parent().map(|p| p.to_path_buf()).unwrap_or_default();
    check_scene_str_checked(&text, is_json, &file, overrides, &base_dir, tables)
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
    check_scene_str_checked(text, is_json, file, overrides, base_dir, None)
}

/// [`check_scene_str`] with `tables` checking the engine tables (see [`load_scene_checked`]).
pub fn check_scene_str_checked(
    text: &str,
    is_json: bool,
    file: &str,
    overrides: &[String],
    base_dir: &Path,
    tables: Option<super::TableCheck>,
) -> Result<Scene, SceneError> {
    let mut scene = parse_scene_str(text, is_json, file, overrides)?;
    scene.base_dir = base_dir.to_path_buf();
    scene.source = file.to_string();
    super::validate::validate(&scene, tables)?;
    Ok(scene)
}

/// Parse scene text (no validation beyond the format). `file` names the source in messages.
/// `[output] interval = ...` is the scene's output sampling (`output_interval`, the older
/// top-level spelling, is still read; both at once is an error).
fn output_table(value: &mut serde_json::Value) -> Result<(), (String, String)> {
    let obj = value.as_object_mut().expect("checked to be a table");
    let Some(out) = obj.remove("output") else {
        return Ok(());
    };
    let serde_json::Value::Object(mut table) = out else {
        return Err((
            "output".into(),
            "must be a table (`[output]` with `interval`)".into(),
        ));
    };
    if let Some(interval) = table.remove("interval") {
        if obj.contains_key("output_interval") {
            return Err((
                "output.interval".into(),
                "given twice (also as `output_interval`); keep `[output] interval`".into(),
            ));
        }
        obj.insert("output_interval".into(), interval);
    }
    if let Some(k) = table.keys().next() {
        return Err((
            format!("output.{k}"),
            "unknown field; `[output]` has `interval` (s)".into(),
        ));
    }
    Ok(())
}

/// Whether the override `set` (`KEY=VALUE`) sets `key`, or a table or list holding it.
pub fn override_covers(set: &str, key: &str) -> bool {
    let Some((k, _)) = set.split_once('=') else {
        return false;
    };
    let k = k.trim();
    k == key || key.starts_with(&format!("{k}.")) || key.starts_with(&format!("{k}["))
}

/// A list of `KEY=VALUE` overrides giving no key twice (of one list the last would win
/// without a word; later lists, e.g. a configuration's over a study's, may replace a key).
pub fn check_override_keys(sets: &[String]) -> Result<(), String> {
    for (k, s) in sets.iter().enumerate() {
        let key = |s: &str| s.split_once('=').map(|(k, _)| k.trim().to_string());
        if let Some(mine) = key(s)
            && sets[..k].iter().any(|o| key(o).as_ref() == Some(&mine))
        {
            return Err(format!("`{mine}` is given twice"));
        }
    }
    Ok(())
}

/// A JSON value none of whose objects gives a key twice (serde_json's own `Value` keeps the
/// last of two, so `"duration": 0.1, "duration": 5` would run for 5 s without a word; TOML
/// refuses a repeated key itself).
struct UniqueKeys(serde_json::Value);

impl<'de> serde::Deserialize<'de> for UniqueKeys {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(UniqueKeysVisitor).map(UniqueKeys)
    }
}

struct UniqueKeysVisitor;

impl<'de> serde::de::Visitor<'de> for UniqueKeysVisitor {
    type Value = serde_json::Value;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a JSON value")
    }
    fn visit_bool<E>(self, v: bool) -> Result<Self::Value, E> {
        Ok(v.into())
    }
    fn visit_i64<E>(self, v: i64) -> Result<Self::Value, E> {
        Ok(v.into())
    }
    fn visit_u64<E>(self, v: u64) -> Result<Self::Value, E> {
        Ok(v.into())
    }
    fn visit_f64<E>(self, v: f64) -> Result<Self::Value, E> {
        Ok(serde_json::Number::from_f64(v).map_or(serde_json::Value::Null, Into::into))
    }
    fn visit_str<E>(self, v: &str) -> Result<Self::Value, E> {
        Ok(v.into())
    }
    fn visit_unit<E>(self) -> Result<Self::Value, E> {
        Ok(serde_json::Value::Null)
    }
    fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut out = Vec::new();
        while let Some(UniqueKeys(v)) = seq.next_element()? {
            out.push(v);
        }
        Ok(serde_json::Value::Array(out))
    }
    fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
        let mut out = serde_json::Map::new();
        while let Some(key) = map.next_key::<String>()? {
            if out.contains_key(&key) {
                return Err(serde::de::Error::custom(format!(
                    "the key `{key}` is given twice"
                )));
            }
            let UniqueKeys(v) = map.next_value()?;
            out.insert(key, v);
        }
        Ok(serde_json::Value::Object(out))
    }
}

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
        serde_json::from_str::<UniqueKeys>(text.strip_prefix('\u{feff}').unwrap_or(text))
            .map(|v| v.0)
            .map_err(|e| {
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
    output_table(&mut value).map_err(|(field, m)| SceneError::new(file, field, m))?;
    let engines = engine_tables(&mut value);
    let obj = value.as_object().expect("checked to be a table");
    if let Some(k) = obj
        .keys()
        .find(|k| !super::SCENE_FIELDS.contains(&k.as_str()))
    {
        return Err(SceneError::new(
            file,
            k,
            format!(
                "unknown field `{k}` (a scene's fields: {}; an engine's settings are a table, \
                 `[{k}]` or `--set {k}.SETTING=VALUE`)",
                super::SCENE_FIELDS.join(", ")
            ),
        ));
    }
    let mut scene: Scene = serde_path_to_error::deserialize(&value).map_err(|e| {
        let message = e.inner().to_string();
        let mut field = e.path().to_string();
        if let Some(key) = key_of_wrong_number(&value, e.path(), &message) {
            field = format!("{field}.{key}");
        }
        if field == "." {
            field = "(top level)".to_string();
        }
        SceneError::new(file, field, clean_serde_message(&message))
    })?;
    scene.source = file.to_string();
    scene.engines = engines;
    Ok(scene)
}

/// Take the engine tables out of the top level: every table that is not a scene field
/// ([`super::SCENE_FIELDS`]). Other keys that are not scene fields stay, to be refused.
fn engine_tables(value: &mut serde_json::Value) -> super::EngineTables {
    let obj = value.as_object_mut().expect("checked to be a table");
    let keys: Vec<String> = obj
        .iter()
        .filter(|(k, v)| v.is_object() && !super::SCENE_FIELDS.contains(&k.as_str()))
        .map(|(k, _)| k.clone())
        .collect();
    keys.into_iter()
        .filter_map(|k| obj.remove(&k).map(|v| (k, v)))
        .collect()
}

fn toml_syntax_error(file: &str, text: &str, e: &toml::de::Error) -> SceneError {
    let (line, message) = toml_error_at(text, e, "(file)");
    SceneError::new(file, line, message)
}

/// A TOML file's fields: its syntax first (an error names its line), then the fields (an error
/// names its field; `whole` where it concerns the file as a whole, e.g. a missing field).
pub(crate) fn toml_fields<T: serde::de::DeserializeOwned>(
    file: &str,
    text: &str,
    whole: &str,
) -> Result<T, SceneError> {
    let table: toml::Table = toml::from_str(text).map_err(|e| {
        let (line, message) = toml_error_at(text, &e, whole);
        SceneError::new(file, line, message)
    })?;
    serde_path_to_error::deserialize(toml::Value::Table(table)).map_err(|e| {
        let field = e.path().to_string();
        let message = e.into_inner().message().trim().replace('\n', " ");
        SceneError::new(
            file,
            if field == "." { whole.into() } else { field },
            message,
        )
    })
}

/// Where a TOML syntax error is in `text` (`line L`, or `fallback` where the error has no
/// place) and its message on one line, for the one-line errors of every file read as TOML.
pub(crate) fn toml_error_at(text: &str, e: &toml::de::Error, fallback: &str) -> (String, String) {
    let line = e
        .span()
        .map(|s| text[..s.start.min(text.len())].lines().count().max(1))
        .map(|l| format!("line {l}"))
        .unwrap_or_else(|| fallback.to_string());
    (
        line,
        format!("invalid TOML: {}", e.message().trim().replace('\n', " ")),
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

/// The key that holds the value a "wrong type where a number belongs" `message` is about, when
/// the error's `path` stops at the table that holds it: a tagged table (an excitation, whose
/// `kind` picks its fields) is read whole before its fields, so its errors name the table only.
/// `None` unless exactly one key of that table holds a value of the type the message names.
fn key_of_wrong_number(
    value: &serde_json::Value,
    path: &serde_path_to_error::Path,
    message: &str,
) -> Option<String> {
    use serde::de::Unexpected;
    use serde_path_to_error::Segment;
    let got = message
        .trim()
        .strip_prefix("invalid type: ")?
        .strip_suffix(", expected f64")?;
    let mut at = value;
    for segment in path.iter() {
        at = match segment {
            Segment::Map { key } => at.get(key)?,
            Segment::Seq { index } => at.get(index)?,
            _ => return None,
        };
    }
    let described = |v: &serde_json::Value| match v {
        serde_json::Value::String(s) => Unexpected::Str(s).to_string(),
        serde_json::Value::Bool(b) => Unexpected::Bool(*b).to_string(),
        serde_json::Value::Array(_) => Unexpected::Seq.to_string(),
        serde_json::Value::Object(_) => Unexpected::Map.to_string(),
        _ => String::new(),
    };
    let mut keys = at
        .as_object()?
        .iter()
        .filter(|(_, v)| described(v) == got)
        .map(|(k, _)| k);
    match (keys.next(), keys.next()) {
        (Some(k), None) => Some(k.clone()),
        _ => None,
    }
}

/// A deserialisation message; a wrong type where a number belongs is said
/// plainly (scene values are bare numbers in SI units: `duration = 5`, never `"5 s"`).
pub(super) fn clean_serde_message(m: &str) -> String {
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

/// One step of an override path: a table key or an array index.
#[derive(Debug, Clone, PartialEq)]
enum Segment {
    Key(String),
    Index(usize),
}

/// Parse `a.b[1].c` into its segments.
fn parse_key(key: &str) -> Result<Vec<Segment>, String> {
    let mut segs = Vec::new();
    for part in key.split('.') {
        let (name, mut rest) = match part.find('[') {
            Some(i) => part.split_at(i),
            None => (part, ""),
        };
        if name.is_empty() {
            return Err(format!("`{key}` has an empty component"));
        }
        if name.contains(']') {
            return Err(format!("`{key}`: `]` without an opening `[`"));
        }
        segs.push(Segment::Key(name.to_string()));
        while !rest.is_empty() {
            let inner = rest
                .strip_prefix('[')
                .ok_or_else(|| format!("`{key}`: unexpected `{rest}` after an index"))?;
            let close = inner
                .find(']')
                .ok_or_else(|| format!("`{key}`: `[` without a closing `]`"))?;
            let idx = &inner[..close];
            if idx.is_empty() || !idx.bytes().all(|b| b.is_ascii_digit()) {
                return Err(format!(
                    "`{key}`: `[{idx}]` is not an array index (a whole number counted from 0)"
                ));
            }
            let i = idx
                .parse::<usize>()
                .map_err(|_| format!("`{key}`: the index {idx} is out of range"))?;
            segs.push(Segment::Index(i));
            rest = &inner[close + 1..];
        }
    }
    Ok(segs)
}

fn show_path(segs: &[Segment]) -> String {
    let mut s = String::new();
    for seg in segs {
        match seg {
            Segment::Key(k) => {
                if !s.is_empty() {
                    s.push('.');
                }
                s.push_str(k);
            }
            Segment::Index(i) => s.push_str(&format!("[{i}]")),
        }
    }
    s
}

/// Set `a.b.c=value` (or `a.b[i].c=value`, indexing an array that the scene has) in a JSON
/// tree; the value is parsed as a TOML value when it can be, otherwise taken as a string.
pub fn apply_override(root: &mut serde_json::Value, assignment: &str) -> Result<(), String> {
    let (key, raw) = assignment
        .split_once('=')
        .ok_or_else(|| format!("`{assignment}` is not of the form key.path=value"))?;
    let key = key.trim();
    if key.is_empty() {
        return Err(format!("`{assignment}` has an empty key"));
    }
    let segs = parse_key(key)?;
    // One value: a line break would let the TOML document hold more than `v` (its other keys
    // were dropped without a word).
    if raw.contains(['\n', '\r']) {
        return Err(format!("`{key}`: the value holds a line break"));
    }
    let parsed: serde_json::Value =
        match toml::from_str::<toml::Table>(&format!("v = {}", raw.trim())) {
            Ok(t) => {
                // JSON has no NaN or infinity: caught here, as in a scene file.
                reject_non_finite(&t["v"], key.to_string(), "--set")
                    .map_err(|e| format!("`{key}`: {}", e.message))?;
                serde_json::to_value(&t["v"]).map_err(|e| e.to_string())?
            }
            Err(_) => serde_json::Value::String(raw.trim().to_string()),
        };
    let mut node = root;
    for (k, seg) in segs.iter().enumerate() {
        let here = show_path(&segs[..k]);
        let last = k + 1 == segs.len();
        match seg {
            Segment::Key(name) => {
                if node.is_array() {
                    // `blocks.0.width` is the dotted spelling of `blocks[0].width`.
                    let example = match name.parse::<usize>() {
                        Ok(i) => {
                            let mut fixed = segs.clone();
                            fixed[k] = Segment::Index(i);
                            show_path(&fixed)
                        }
                        Err(_) => format!("{here}[0].{name}"),
                    };
                    return Err(format!(
                        "`{key}`: `{here}` is an array: give an index, e.g. `{example}`"
                    ));
                }
                let obj = node
                    .as_object_mut()
                    .ok_or_else(|| format!("`{key}`: `{here}` is not a table"))?;
                if last {
                    obj.insert(name.clone(), parsed);
                    return Ok(());
                }
                if matches!(segs[k + 1], Segment::Index(_)) && !obj.contains_key(name) {
                    return Err(format!(
                        "`{key}`: the scene has no `{}` to index",
                        show_path(&segs[..=k])
                    ));
                }
                node = obj
                    .entry(name.clone())
                    .or_insert_with(|| serde_json::Value::Object(Default::default()));
            }
            Segment::Index(i) => {
                let arr = node
                    .as_array_mut()
                    .ok_or_else(|| format!("`{key}`: `{here}` is not an array"))?;
                let len = arr.len();
                if *i >= len {
                    return Err(format!(
                        "`{key}`: index {i} is out of range (`{here}` has {len} {}{})",
                        if len == 1 { "entry" } else { "entries" },
                        if len > 0 {
                            format!(", indices 0 to {}", len - 1)
                        } else {
                            String::new()
                        }
                    ));
                }
                if last {
                    arr[*i] = parsed;
                    return Ok(());
                }
                node = &mut arr[*i];
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn scene() -> serde_json::Value {
        json!({"duration": 1.0, "blocks": [{"name": "a", "width": 1.0}, {"name": "b", "width": 2.0}]})
    }

    /// An override's value is one value: a line break (which hid further keys) is refused.
    #[test]
    fn an_override_value_with_a_line_break_is_refused() {
        let mut v = scene();
        let e = apply_override(&mut v, "duration=0.2\ngravity=1").unwrap_err();
        assert_eq!(e, "`duration`: the value holds a line break");
        assert_eq!(v, scene());
        apply_override(&mut v, "duration= 0.2 ").unwrap();
        assert_eq!(v["duration"], 0.2);
    }

    /// A JSON scene giving a key twice is refused (serde_json kept the last one), at the top
    /// level and inside a block; a byte-order mark is not an error.
    #[test]
    fn a_json_key_given_twice_is_refused() {
        let good = r#"{"name": "s", "duration": 0.1, "blocks": [{"name": "b", "width": 0.4, "height": 1.0}]}"#;
        let s = parse_scene_str(&format!("\u{feff}{good}"), true, "s.json", &[]).unwrap();
        assert_eq!((s.duration, s.blocks[0].width), (0.1, 0.4));
        for (text, key) in [
            (
                good.replace(r#""duration": 0.1"#, r#""duration": 0.1, "duration": 5.0"#),
                "duration",
            ),
            (
                good.replace(r#""width": 0.4"#, r#""width": 0.4, "width": 4"#),
                "width",
            ),
        ] {
            let e = parse_scene_str(&text, true, "s.json", &[])
                .unwrap_err()
                .to_string();
            assert!(
                e.starts_with("s.json: line 1: invalid JSON: the key `")
                    && e.contains(&format!("`{key}` is given twice")),
                "{e}"
            );
        }
    }

    #[test]
    fn a_top_level_key_that_is_no_scene_field_nor_a_table_is_refused_by_name() {
        let text =
            "name = \"s\"\nduration = 1.0\n[[blocks]]\nname = \"b\"\nwidth = 0.4\nheight = 1.0\n";
        assert!(parse_scene_str(text, false, "s.toml", &["native.dt=1e-3".into()]).is_ok());
        for set in ["native=3", "rapier=[1]", "colour=\"red\""] {
            let err = parse_scene_str(text, false, "s.toml", &[set.into()])
                .unwrap_err()
                .to_string();
            let key = set.split('=').next().unwrap();
            assert!(
                err.starts_with(&format!(
                    "s.toml: {key}: unknown field `{key}` (a scene's fields: name, duration"
                )) && err.contains(&format!("`--set {key}.SETTING=VALUE`")),
                "{set}: {err}"
            );
        }
    }

    #[test]
    fn override_sets_nested_keys_and_array_elements() {
        let mut v = scene();
        apply_override(&mut v, "native.dt=5e-4").unwrap();
        apply_override(&mut v, "blocks[1].width=0.5").unwrap();
        apply_override(&mut v, "blocks[0].density = 3000").unwrap();
        assert_eq!(v["native"]["dt"], json!(5e-4));
        assert_eq!(v["blocks"][1]["width"], json!(0.5));
        assert_eq!(v["blocks"][0]["width"], json!(1.0));
        assert_eq!(v["blocks"][0]["density"], json!(3000));
        apply_override(&mut v, "blocks[0]={name = \"c\", width = 3.0}").unwrap();
        assert_eq!(v["blocks"][0], json!({"name": "c", "width": 3.0}));
    }

    #[test]
    fn bad_indices_are_one_line_errors() {
        let cases = [
            (
                "blocks[2].width=1",
                "index 2 is out of range (`blocks` has 2 entries, indices 0 to 1)",
            ),
            ("blocks[-1].width=1", "`[-1]` is not an array index"),
            ("blocks[x].width=1", "`[x]` is not an array index"),
            ("blocks[].width=1", "`[]` is not an array index"),
            ("blocks[1.width=1", "`[` without a closing `]`"),
            ("blocks]1[.width=1", "`]` without an opening `[`"),
            ("blocks[0]x.width=1", "unexpected `x` after an index"),
            (
                "blocks.width=1",
                "`blocks` is an array: give an index, e.g. `blocks[0].width`",
            ),
            (
                "blocks.1.width=1",
                "`blocks` is an array: give an index, e.g. `blocks[1].width`",
            ),
            ("duration[0]=1", "`duration` is not an array"),
            ("native[0].dt=1", "the scene has no `native` to index"),
            ("blocks[99999999999999999999999].width=1", "out of range"),
        ];
        for (a, want) in cases {
            let mut v = scene();
            let e = apply_override(&mut v, a).unwrap_err();
            assert!(e.contains(want), "{a}: {e}");
            assert!(!e.contains('\n'), "{a}: {e}");
            assert_eq!(v, scene(), "{a} changed the scene");
        }
    }
}

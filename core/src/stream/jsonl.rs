//! facewire's own stream format: one JSON object per line (JSONL). It is the format that
//! can carry everything a [`Frame`] holds, so recorded streams and producers that speak
//! JSON use it. The schema is in `docs/STREAMS.md`; the reader checks every field and
//! names it in its errors.

use std::io::{BufRead, Write};

use serde::ser::{SerializeMap, Serializer};
use serde_json::{Map, Value};

use super::blendshapes::{arkit_index, ARKIT_BLENDSHAPES};
use super::error::{Location, StreamError};
use super::frame::{ExpressionFap, Frame, VisemeFap};
use super::lines::{Decoding, LineReader};
use super::reader::{FrameReader, LineFormat};
use super::strict_json::{self, StrictJsonError};
use super::visemes::{single, VisemeScheme, VISEMES};
use crate::mask::fap::{fap_by_name, fap_info, FAPS};
use crate::mask::Mask;

/// The keys a JSONL frame object may have.
pub const JSONL_FIELDS: [&str; 11] = [
    "seq",
    "t",
    "label",
    "au",
    "fap",
    "arkit",
    "head_rotation_rad",
    "head_translation",
    "controls",
    "viseme",
    "expression",
];

const VISEME_FIELDS: [&str; 4] = ["select1", "select2", "blend", "definition"];
const EXPRESSION_FIELDS: [&str; 6] = [
    "select1",
    "intensity1",
    "select2",
    "intensity2",
    "init_face",
    "definition",
];

/// Reads JSONL frames from any [`BufRead`], one line at a time. Blank lines are skipped.
pub type JsonlReader<'m, R> = FrameReader<R, JsonlFormat<'m>>;

/// JSONL's lines: one frame each, its keys resolved by the mask.
pub struct JsonlFormat<'m> {
    mask: &'m Mask,
}

impl<'m, R: BufRead> JsonlReader<'m, R> {
    /// `mask` resolves the `au` keys and sizes `controls`.
    pub fn new(input: R, mask: &'m Mask) -> Self {
        FrameReader::with_format(input, JsonlFormat { mask })
    }
}

impl LineFormat for JsonlFormat<'_> {
    const DECODING: Decoding = Decoding::Utf8;
    const SEQ_FIELD: &'static str = "seq";
    const TIME_FIELD: &'static str = "t";

    fn read_frame<R: BufRead>(
        &mut self,
        lines: &mut LineReader<R>,
        line: &mut String,
        _frames_read: u64,
    ) -> Result<Option<(Frame, Location)>, StreamError> {
        if !lines.read_data_line(line, false)? {
            return Ok(None);
        }
        let at = lines.location();
        Ok(Some((parse_frame(&at, line, self.mask)?, at)))
    }
}

/// Parses one frame that arrives on its own (a WebSocket text message) rather than as a
/// line of a file, checked like every frame ([`Frame::check`]); `origin` names it in
/// errors (`message 17`). Sequence and time order across messages are the caller's to
/// check.
pub fn parse_message(origin: &str, text: &str, mask: &Mask) -> Result<Frame, StreamError> {
    let at = Location::line(Some(origin.into()), 1);
    parse_frame(&at, text, mask)
}

fn parse_frame(at: &Location, text: &str, mask: &Mask) -> Result<Frame, StreamError> {
    let value = strict_json::parse(text).map_err(|e| match e {
        StrictJsonError::Syntax(e) => StreamError::syntax(at, "json", format!("invalid JSON: {e}")),
        StrictJsonError::RepeatedKey(path) => {
            StreamError::syntax(at, &path, "the key appears twice; name it once")
        }
    })?;
    let Value::Object(object) = value else {
        return Err(StreamError::syntax(at, "frame", "expected a JSON object"));
    };
    let mut frame = Frame::default();
    let (mut seq, mut time) = (None, None);
    for (key, value) in &object {
        match key.as_str() {
            "seq" => seq = Some(parse_u64(at, value, "seq")?),
            "t" => time = Some(parse_f64(at, value, "t")?),
            "label" => frame.label = parse_label(at, value)?,
            "au" => frame.animation = parse_animation(at, value, mask)?,
            "fap" => frame.faps = parse_faps(at, value)?,
            "arkit" => frame.arkit = parse_arkit(at, value)?,
            "head_rotation_rad" => {
                frame.head_rotation_rad = parse_optional_vec3(at, value, "head_rotation_rad")?
            }
            "head_translation" => {
                frame.head_translation = parse_optional_vec3(at, value, "head_translation")?
            }
            "controls" => frame.controls = parse_controls(at, value, mask)?,
            "viseme" => frame.viseme = parse_viseme(at, value)?,
            "expression" => frame.expression = parse_expression(at, value)?,
            other => {
                return Err(StreamError::UnknownName {
                    at: at.clone(),
                    field: other.to_string(),
                    what: "field",
                    name: other.to_string(),
                    valid: JSONL_FIELDS.join(", "),
                })
            }
        }
    }
    frame.seq = seq.ok_or_else(|| StreamError::syntax(at, "seq", "missing (every frame needs one)"))?;
    frame.time_s = time.ok_or_else(|| StreamError::syntax(at, "t", "missing (every frame needs one)"))?;
    frame.check_at(at, Some(mask))?;
    Ok(frame)
}

fn parse_u64(at: &Location, value: &Value, field: &str) -> Result<u64, StreamError> {
    value.as_u64().ok_or_else(|| StreamError::NotANumber {
        at: at.clone(),
        field: field.to_string(),
        found: value.to_string(),
        expected: "a non-negative integer",
    })
}

fn parse_i32(at: &Location, value: &Value, field: &str) -> Result<i32, StreamError> {
    value
        .as_i64()
        .and_then(|v| i32::try_from(v).ok())
        .ok_or_else(|| StreamError::NotANumber {
            at: at.clone(),
            field: field.to_string(),
            found: value.to_string(),
            expected: "a 32-bit integer",
        })
}

fn parse_f64(at: &Location, value: &Value, field: &str) -> Result<f64, StreamError> {
    let number = value.as_f64().ok_or_else(|| StreamError::NotANumber {
        at: at.clone(),
        field: field.to_string(),
        found: value.to_string(),
        expected: "a number",
    })?;
    number
        .is_finite()
        .then_some(number)
        .ok_or_else(|| not_finite(at, value, field))
}

/// A JSON number as an `f32`; values beyond `f32`'s range are not finite.
fn parse_f32(at: &Location, value: &Value, field: &str) -> Result<f32, StreamError> {
    let number = parse_f64(at, value, field)? as f32;
    number
        .is_finite()
        .then_some(number)
        .ok_or_else(|| not_finite(at, value, field))
}

fn not_finite(at: &Location, value: &Value, field: &str) -> StreamError {
    StreamError::NotFinite {
        at: at.clone(),
        field: field.to_string(),
        found: value.to_string(),
    }
}

fn parse_label(at: &Location, value: &Value) -> Result<Option<String>, StreamError> {
    match value {
        Value::Null => Ok(None),
        Value::String(label) => Ok(Some(label.clone())),
        other => Err(StreamError::syntax(
            at,
            "label",
            format!("expected a string or null, found {other}"),
        )),
    }
}

fn as_object<'v>(
    at: &Location,
    value: &'v Value,
    field: &str,
) -> Result<&'v Map<String, Value>, StreamError> {
    value
        .as_object()
        .ok_or_else(|| StreamError::syntax(at, field, format!("expected an object, found {value}")))
}

fn as_array<'v>(at: &Location, value: &'v Value, field: &str) -> Result<&'v [Value], StreamError> {
    value
        .as_array()
        .map(Vec::as_slice)
        .ok_or_else(|| StreamError::syntax(at, field, format!("expected an array, found {value}")))
}

/// Sorts `(index, value)` entries by index, failing when two keys name the same index.
fn sort_unique<I: Ord + Copy, V>(
    at: &Location,
    map_field: &str,
    what: &'static str,
    mut entries: Vec<(I, V, String)>,
) -> Result<Vec<(I, V)>, StreamError> {
    entries.sort_by_key(|(index, _, _)| *index);
    for pair in entries.windows(2) {
        if pair[0].0 == pair[1].0 {
            return Err(StreamError::Duplicate {
                at: at.clone(),
                field: format!("{map_field}.{}", pair[1].2),
                what,
                other: format!("{:?}", pair[0].2),
            });
        }
    }
    Ok(entries.into_iter().map(|(i, v, _)| (i, v)).collect())
}

fn parse_animation(at: &Location, value: &Value, mask: &Mask) -> Result<Vec<(u16, f32)>, StreamError> {
    let mut entries = Vec::new();
    for (key, weight) in as_object(at, value, "au")? {
        let field = format!("au.{key}");
        let unit = mask
            .animation_unit(key)
            .map_err(|source| StreamError::UnknownUnit {
                at: at.clone(),
                field: field.clone(),
                source: Box::new(source),
            })?;
        let unit = u16::try_from(unit).map_err(|_| StreamError::OutOfRange {
            at: at.clone(),
            field: field.clone(),
            found: unit.to_string(),
            expected: "a unit index below 65536".to_string(),
        })?;
        entries.push((unit, parse_f32(at, weight, &field)?, key.clone()));
    }
    sort_unique(at, "au", "animation unit", entries)
}

/// A FAP key: its number (`"3"`), its standard name (`open_jaw`), `fap3` or
/// `fap3_open_jaw`, case-insensitively.
fn resolve_fap(key: &str) -> Option<u8> {
    let lower = key.trim().to_ascii_lowercase();
    if let Ok(number) = lower.parse::<u8>() {
        return fap_info(number).map(|info| info.number);
    }
    if let Some(rest) = lower.strip_prefix("fap") {
        let digits = rest.len() - rest.trim_start_matches(|c: char| c.is_ascii_digit()).len();
        let (number, name) = rest.split_at(digits);
        let info = fap_info(number.parse().ok()?)?;
        return match name.strip_prefix('_') {
            None if name.is_empty() => Some(info.number),
            Some(name) if name == info.name => Some(info.number),
            _ => None,
        };
    }
    fap_by_name(&lower).map(|info| info.number)
}

fn parse_faps(at: &Location, value: &Value) -> Result<Vec<(u8, f32)>, StreamError> {
    let mut entries = Vec::new();
    for (key, count) in as_object(at, value, "fap")? {
        let field = format!("fap.{key}");
        let number = resolve_fap(key).ok_or_else(|| StreamError::UnknownName {
            at: at.clone(),
            field: field.clone(),
            what: "FAP",
            name: key.clone(),
            valid: "a FAP number 3..=68 or a name: ".to_string()
                + &FAPS[2..].iter().map(|f| f.name).collect::<Vec<_>>().join(", "),
        })?;
        entries.push((number, parse_f32(at, count, &field)?, key.clone()));
    }
    sort_unique(at, "fap", "FAP", entries)
}

fn parse_arkit(at: &Location, value: &Value) -> Result<Vec<(u8, f32)>, StreamError> {
    let mut entries = Vec::new();
    for (key, weight) in as_object(at, value, "arkit")? {
        let field = format!("arkit.{key}");
        let index = key
            .parse::<u8>()
            .ok()
            .filter(|&i| usize::from(i) < ARKIT_BLENDSHAPES.len())
            .or_else(|| arkit_index(key))
            .ok_or_else(|| StreamError::UnknownName {
                at: at.clone(),
                field: field.clone(),
                what: "ARKit blendshape",
                name: key.clone(),
                valid: "an index 0..52 or one of ".to_string() + &ARKIT_BLENDSHAPES.join(", "),
            })?;
        entries.push((index, parse_f32(at, weight, &field)?, key.clone()));
    }
    sort_unique(at, "arkit", "ARKit blendshape", entries)
}

fn parse_vec3(at: &Location, value: &Value, field: &str) -> Result<[f32; 3], StreamError> {
    let items = as_array(at, value, field)?;
    if items.len() != 3 {
        return Err(StreamError::WrongLength {
            at: at.clone(),
            field: field.to_string(),
            found: items.len(),
            expected: "3 (x, y, z)".to_string(),
        });
    }
    let mut out = [0.0; 3];
    for (k, (slot, item)) in out.iter_mut().zip(items).enumerate() {
        *slot = parse_f32(at, item, &format!("{field}[{k}]"))?;
    }
    Ok(out)
}

fn parse_optional_vec3(at: &Location, value: &Value, field: &str) -> Result<Option<[f32; 3]>, StreamError> {
    match value {
        Value::Null => Ok(None),
        value => parse_vec3(at, value, field).map(Some),
    }
}

fn parse_controls(at: &Location, value: &Value, mask: &Mask) -> Result<Option<Vec<[f32; 3]>>, StreamError> {
    if value.is_null() {
        return Ok(None);
    }
    let items = as_array(at, value, "controls")?;
    if items.len() != mask.vertices.len() {
        return Err(StreamError::WrongLength {
            at: at.clone(),
            field: "controls".to_string(),
            found: items.len(),
            expected: format!("one per mask vertex ({})", mask.vertices.len()),
        });
    }
    items
        .iter()
        .enumerate()
        .map(|(i, item)| parse_vec3(at, item, &format!("controls[{i}]")))
        .collect::<Result<Vec<_>, _>>()
        .map(Some)
}

/// Reads the integer fields `names` of the object `field`, all required, no others.
fn parse_int_fields<const N: usize>(
    at: &Location,
    value: &Value,
    field: &str,
    names: [&str; N],
) -> Result<[i32; N], StreamError> {
    let object = as_object(at, value, field)?;
    if let Some(extra) = object.keys().find(|k| !names.contains(&k.as_str())) {
        return Err(StreamError::UnknownName {
            at: at.clone(),
            field: format!("{field}.{extra}"),
            what: "field",
            name: extra.clone(),
            valid: names.join(", "),
        });
    }
    let mut out = [0; N];
    for (slot, name) in out.iter_mut().zip(names) {
        let item_field = format!("{field}.{name}");
        let item = object
            .get(name)
            .ok_or_else(|| StreamError::syntax(at, &item_field, "missing"))?;
        *slot = parse_i32(at, item, &item_field)?;
    }
    Ok(out)
}

fn parse_viseme(at: &Location, value: &Value) -> Result<Option<VisemeFap>, StreamError> {
    if value.is_null() {
        return Ok(None);
    }
    // A text-to-speech viseme: {"oculus": 10} or {"oculus": "aa"}, {"microsoft": 21}.
    if let Some((key, id)) = value
        .as_object()
        .filter(|o| o.len() == 1)
        .and_then(|o| o.iter().next())
    {
        let scheme = [VisemeScheme::Oculus, VisemeScheme::Microsoft]
            .into_iter()
            .find(|s| s.key() == key);
        if let Some(scheme) = scheme {
            let by_name = id
                .as_str()
                .filter(|_| scheme == VisemeScheme::Oculus)
                .and_then(|name| VISEMES.iter().find(|v| v.oculus == name))
                .map(|v| i64::from(v.number));
            let number = by_name.or_else(|| id.as_i64()).unwrap_or(-1);
            return scheme
                .fap1(number, &crate::quote::clip(&id.to_string()))
                .map(Some)
                .map_err(|message| StreamError::syntax(at, &format!("viseme.{key}"), message));
        }
    }
    let [select1, select2, blend, definition] = parse_int_fields(at, value, "viseme", VISEME_FIELDS)?;
    Ok(Some(VisemeFap {
        select1,
        select2,
        blend,
        definition,
    }))
}

fn parse_expression(at: &Location, value: &Value) -> Result<Option<ExpressionFap>, StreamError> {
    if value.is_null() {
        return Ok(None);
    }
    let [select1, intensity1, select2, intensity2, init_face, definition] =
        parse_int_fields(at, value, "expression", EXPRESSION_FIELDS)?;
    Ok(Some(ExpressionFap {
        select1,
        intensity1,
        select2,
        intensity2,
        init_face,
        definition,
    }))
}

/// Writes frames as JSONL, one line each, keys resolved to names: unit keys for `au`
/// (`jaw_drop`, `fap3_open_jaw`), the standard FAP names for `fap`, ARKit names for
/// `arkit`. Fields a frame does not use are left out. Wrap a file in a `BufWriter`.
pub struct JsonlWriter<'m, W> {
    out: W,
    mask: &'m Mask,
    line: Vec<u8>,
}

/// `(key, value)` pairs serialized as a JSON object in their order.
struct OrderedMap<'k>(Vec<(&'k str, f32)>);

impl serde::Serialize for OrderedMap<'_> {
    fn serialize<S: Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.0.len()))?;
        for (key, value) in &self.0 {
            map.serialize_entry(key, value)?;
        }
        map.end()
    }
}

impl OrderedMap<'_> {
    fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// A frame's viseme as written: one viseme held fully by its Oculus name (`{"oculus":
/// "PP"}`, how a text-to-speech engine or `facewire speech` says it), anything else as
/// FAP 1's four fields. Both read back as the same [`VisemeFap`].
#[derive(serde::Serialize)]
#[serde(untagged)]
enum JsonViseme<'f> {
    Named { oculus: &'static str },
    Fap(&'f VisemeFap),
}

impl<'f> JsonViseme<'f> {
    fn of(viseme: &'f VisemeFap) -> Self {
        let held = usize::try_from(viseme.select1)
            .ok()
            .filter(|_| *viseme == single(viseme.select1 as u8))
            .and_then(|number| VISEMES.get(number));
        match held {
            Some(v) => JsonViseme::Named { oculus: v.oculus },
            None => JsonViseme::Fap(viseme),
        }
    }
}

#[derive(serde::Serialize)]
struct JsonFrame<'f> {
    seq: u64,
    t: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    label: Option<&'f str>,
    #[serde(skip_serializing_if = "OrderedMap::is_empty")]
    au: OrderedMap<'f>,
    #[serde(skip_serializing_if = "OrderedMap::is_empty")]
    fap: OrderedMap<'f>,
    #[serde(skip_serializing_if = "OrderedMap::is_empty")]
    arkit: OrderedMap<'f>,
    #[serde(skip_serializing_if = "Option::is_none")]
    head_rotation_rad: Option<[f32; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    head_translation: Option<[f32; 3]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    controls: Option<&'f [[f32; 3]]>,
    #[serde(skip_serializing_if = "Option::is_none")]
    viseme: Option<JsonViseme<'f>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    expression: Option<&'f ExpressionFap>,
}

fn invalid(seq: u64, field: impl Into<String>, reason: impl Into<String>) -> StreamError {
    StreamError::InvalidFrame {
        seq,
        field: field.into(),
        reason: reason.into(),
    }
}

impl<'m, W: Write> JsonlWriter<'m, W> {
    /// `mask` names the animation units and sizes `controls`.
    pub fn new(out: W, mask: &'m Mask) -> Self {
        JsonlWriter {
            out,
            mask,
            line: Vec::new(),
        }
    }

    /// Writes one frame as one line. Fails, writing nothing, on a frame that
    /// [`Frame::check`] refuses (what is written always reads back).
    pub fn write_frame(&mut self, frame: &Frame) -> Result<(), StreamError> {
        frame.check(self.mask)?;
        let seq = frame.seq;
        let mut au = Vec::with_capacity(frame.animation.len());
        for &(unit, weight) in &frame.animation {
            let key = self
                .mask
                .animation_units
                .get(usize::from(unit))
                .map(|u| u.key.as_str())
                .ok_or_else(|| invalid(seq, format!("au[{unit}]"), "the mask has no such unit"))?;
            au.push((key, weight));
        }
        let mut fap = Vec::with_capacity(frame.faps.len());
        for &(number, count) in &frame.faps {
            let name = fap_info(number)
                .map(|info| info.name)
                .ok_or_else(|| invalid(seq, format!("fap[{number}]"), "not a FAP 3..=68"))?;
            fap.push((name, count));
        }
        let mut arkit = Vec::with_capacity(frame.arkit.len());
        for &(index, weight) in &frame.arkit {
            let name = ARKIT_BLENDSHAPES
                .get(usize::from(index))
                .ok_or_else(|| invalid(seq, format!("arkit[{index}]"), "not an index 0..52"))?;
            arkit.push((*name, weight));
        }
        let json = JsonFrame {
            seq,
            t: frame.time_s,
            label: frame.label.as_deref(),
            au: OrderedMap(au),
            fap: OrderedMap(fap),
            arkit: OrderedMap(arkit),
            head_rotation_rad: frame.head_rotation_rad,
            head_translation: frame.head_translation,
            controls: frame.controls.as_deref(),
            viseme: frame.viseme.as_ref().map(JsonViseme::of),
            expression: frame.expression.as_ref(),
        };
        self.line.clear();
        serde_json::to_writer(&mut self.line, &json).map_err(|e| invalid(seq, "frame", e.to_string()))?;
        self.line.push(b'\n');
        self.out.write_all(&self.line)?;
        Ok(())
    }

    /// Flushes and returns the underlying writer.
    pub fn into_inner(mut self) -> Result<W, StreamError> {
        self.out.flush()?;
        Ok(self.out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fap_keys_resolve_by_number_name_and_prefix() {
        assert_eq!(resolve_fap("3"), Some(3));
        assert_eq!(resolve_fap("open_jaw"), Some(3));
        assert_eq!(resolve_fap("FAP3"), Some(3));
        assert_eq!(resolve_fap("fap3_open_jaw"), Some(3));
        assert_eq!(resolve_fap("fap3_push_t_lip"), None);
        assert_eq!(resolve_fap("69"), None);
        assert_eq!(resolve_fap("fap"), None);
        assert_eq!(resolve_fap("smile"), None);
    }

    #[test]
    fn reads_the_documented_example() {
        let mask = Mask::candide3();
        let line = r#"{"seq":0,"t":0.0,"label":"pa","au":{"jaw_drop":0.3,"11":0.01},"fap":{"open_jaw":120,"4":5},"arkit":{"jawOpen":0.5},"head_rotation_rad":[0,0,0.1]}"#;
        let frames: Vec<Frame> = JsonlReader::new(line.as_bytes(), &mask)
            .collect::<Result<_, _>>()
            .unwrap();
        assert_eq!(
            frames,
            [Frame {
                label: Some("pa".into()),
                animation: vec![(1, 0.3), (11, 0.01)],
                faps: vec![(3, 120.0), (4, 5.0)],
                arkit: vec![(17, 0.5)],
                head_rotation_rad: Some([0.0, 0.0, 0.1]),
                ..Frame::at(0, 0.0)
            }]
        );
    }

    #[test]
    fn two_keys_for_one_unit_are_an_error() {
        let mask = Mask::candide3();
        let line = r#"{"seq":0,"t":0,"au":{"jaw_drop":0.3,"1":0.1}}"#;
        let err = JsonlReader::new(line.as_bytes(), &mask)
            .next()
            .unwrap()
            .unwrap_err();
        assert_eq!(
            err.to_string(),
            "line 1: au.jaw_drop: names the same animation unit as \"1\""
        );
    }

    #[test]
    fn writer_writes_resolved_keys_in_order() {
        let mask = Mask::candide3();
        let frame = Frame {
            label: Some("pa".into()),
            animation: vec![(1, 0.3), (25, 0.04)],
            faps: vec![(3, 120.0)],
            arkit: vec![(17, 0.5)],
            ..Frame::at(7, 0.25)
        };
        let mut writer = JsonlWriter::new(Vec::new(), &mask);
        writer.write_frame(&frame).unwrap();
        let text = String::from_utf8(writer.into_inner().unwrap()).unwrap();
        assert_eq!(
            text,
            "{\"seq\":7,\"t\":0.25,\"label\":\"pa\",\"au\":{\"jaw_drop\":0.3,\"fap17_push_t_lip\":0.04},\"fap\":{\"open_jaw\":120.0},\"arkit\":{\"jawOpen\":0.5}}\n"
        );
    }

    #[test]
    fn writer_refuses_what_it_cannot_write_faithfully() {
        let mask = Mask::candide3();
        let mut writer = JsonlWriter::new(Vec::new(), &mask);
        let bad_unit = Frame {
            animation: vec![(65, 0.1)],
            ..Frame::at(3, 0.0)
        };
        assert!(writer
            .write_frame(&bad_unit)
            .unwrap_err()
            .to_string()
            .starts_with("frame 3: au.65: unknown animation unit \"65\"; valid: an index 0..65"));
        let nan = Frame {
            faps: vec![(3, f32::NAN)],
            ..Frame::at(4, 0.0)
        };
        assert_eq!(
            writer.write_frame(&nan).unwrap_err().to_string(),
            "frame 4: fap.open_jaw: NaN is not a finite number"
        );
        assert!(writer.into_inner().unwrap().is_empty());
    }
}

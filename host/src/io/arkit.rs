//! ARKit face captures as Epic's Live Link Face app records them: a CSV whose header is
//! `Timecode,BlendshapeCount,` then one column per channel (ARKit's 52 blendshapes in PascalCase,
//! `EyeBlinkLeft` … `TongueOut`, then the head and eye rotations `HeadYaw` … `RightEyeRoll`), and
//! one row per frame: the timecode `HH:MM:SS:FF.mmm`, the channel count, then one number per
//! channel. This module knows the format only; which channel drives which of an actor's shapes is
//! `aim::arkit`'s business.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

mod names;
pub use names::{ARKIT_SHAPES, LIVE_LINK_FACE_CHANNELS, arkit_bindings, arkit_shapes, comparable};

/// A capture: channel names in column order and one row of values per frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Capture {
    /// Channel names as the header spells them (`JawOpen`, `MouthSmileLeft`, …).
    pub channels: Vec<String>,
    /// The frames in file order.
    pub frames: Vec<CaptureFrame>,
}

/// One row of a capture.
#[derive(Clone, Debug, PartialEq)]
pub struct CaptureFrame {
    /// The row's timecode, as written (`HH:MM:SS:FF.mmm`).
    pub timecode: String,
    /// One finite value per channel, in the header's order.
    pub values: Vec<f32>,
}

/// Why a capture file cannot be read: the file, the 1-based line (0 when the whole file is at
/// fault) and the problem.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{}:{line}: {problem}", path.display())]
pub struct CaptureError {
    /// The capture file.
    pub path: PathBuf,
    /// 1-based line number, or 0 for the whole file.
    pub line: usize,
    /// What is wrong.
    pub problem: String,
}

/// The two columns before the channels.
const LEADING: [&str; 2] = ["Timecode", "BlendshapeCount"];

impl Capture {
    /// Reads a Live Link Face CSV.
    pub fn read(path: &Path) -> Result<Self, CaptureError> {
        let text = std::fs::read_to_string(path).map_err(|e| CaptureError {
            path: path.to_path_buf(),
            line: 0,
            problem: format!("cannot read: {e}"),
        })?;
        Self::parse(path, &text)
    }

    /// Parses the text of a capture; `path` names it in errors.
    pub fn parse(path: &Path, text: &str) -> Result<Self, CaptureError> {
        let fail = |line: usize, problem: String| CaptureError {
            path: path.to_path_buf(),
            line,
            problem,
        };
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l.trim_end_matches('\r')))
            .filter(|(_, l)| !l.trim().is_empty());
        let Some((header_line, header)) = lines.next() else {
            return Err(fail(0, "empty file: no header".into()));
        };
        let fields: Vec<&str> = header.split(',').map(str::trim).collect();
        if fields.len() <= LEADING.len() || fields[..2] != LEADING {
            return Err(fail(
                header_line,
                format!(
                    "not a Live Link Face header: expected `Timecode,BlendshapeCount,` and at least \
                     one channel name, found `{}`",
                    truncate(header)
                ),
            ));
        }
        let channels: Vec<String> = fields[2..].iter().map(|s| s.to_string()).collect();
        for (i, c) in channels.iter().enumerate() {
            if c.is_empty() {
                return Err(fail(
                    header_line,
                    format!("column {} has no channel name", i + 3),
                ));
            }
            if channels[..i].iter().any(|p| p.eq_ignore_ascii_case(c)) {
                return Err(fail(header_line, format!("channel {c} appears twice")));
            }
        }
        let mut frames = Vec::new();
        for (line, row) in lines {
            let fields: Vec<&str> = row.split(',').map(str::trim).collect();
            if fields.len() != channels.len() + 2 {
                return Err(fail(
                    line,
                    format!(
                        "{} fields, the header has {}",
                        fields.len(),
                        channels.len() + 2
                    ),
                ));
            }
            let count: usize = fields[1].parse().map_err(|_| {
                fail(
                    line,
                    format!("BlendshapeCount `{}` is not a whole number", fields[1]),
                )
            })?;
            if count != channels.len() {
                return Err(fail(
                    line,
                    format!(
                        "BlendshapeCount says {count} channels, the header names {}",
                        channels.len()
                    ),
                ));
            }
            let values = fields[2..]
                .iter()
                .zip(&channels)
                .map(|(v, name)| match v.parse::<f32>() {
                    Ok(x) if x.is_finite() => Ok(x),
                    _ => Err(fail(line, format!("{name}: `{v}` is not a finite number"))),
                })
                .collect::<Result<Vec<f32>, _>>()?;
            frames.push(CaptureFrame {
                timecode: fields[0].to_string(),
                values,
            });
        }
        if frames.is_empty() {
            return Err(fail(0, "no frames after the header".into()));
        }
        Ok(Self { channels, frames })
    }

    /// The capture as Live Link Face CSV text (values with four decimals, as the app writes
    /// them to within its precision).
    pub fn to_csv(&self) -> String {
        let mut s = LEADING.join(",");
        for c in &self.channels {
            let _ = write!(s, ",{c}");
        }
        s.push('\n');
        for f in &self.frames {
            let _ = write!(s, "{},{}", f.timecode, self.channels.len());
            for v in &f.values {
                let _ = write!(s, ",{v:.4}");
            }
            s.push('\n');
        }
        s
    }

    /// The column of `channel` (ASCII case-insensitive).
    pub fn channel(&self, channel: &str) -> Option<usize> {
        self.channels
            .iter()
            .position(|c| c.eq_ignore_ascii_case(channel))
    }
}

fn truncate(s: &str) -> String {
    match s.char_indices().nth(60) {
        Some((i, _)) => format!("{}…", &s[..i]),
        None => s.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Capture, CaptureError> {
        Capture::parse(Path::new("cap.csv"), text)
    }

    #[test]
    fn reads_rows_and_round_trips() {
        let text = "Timecode,BlendshapeCount,JawOpen,EyeBlinkLeft\r\n\
                    00:00:01:00.000,2,0.5,0\r\n00:00:01:01.000,2,0.25,1\r\n\r\n";
        let c = parse(text).unwrap();
        assert_eq!(c.channels, ["JawOpen", "EyeBlinkLeft"]);
        assert_eq!(c.frames.len(), 2);
        assert_eq!(c.frames[1].values, [0.25, 1.0]);
        assert_eq!(c.frames[0].timecode, "00:00:01:00.000");
        assert_eq!(c.channel("jawopen"), Some(0));
        assert_eq!(parse(&c.to_csv()).unwrap(), c);
    }

    #[test]
    fn every_malformed_input_names_file_and_line() {
        let cases = [
            ("", "cap.csv:0: empty file"),
            (
                "Time,Count,JawOpen\n0,1,0\n",
                "cap.csv:1: not a Live Link Face header",
            ),
            (
                "Timecode,BlendshapeCount\n0,0\n",
                "cap.csv:1: not a Live Link Face header",
            ),
            (
                "Timecode,BlendshapeCount,JawOpen,jawopen\n",
                "cap.csv:1: channel jawopen appears twice",
            ),
            (
                "Timecode,BlendshapeCount,JawOpen,\n",
                "cap.csv:1: column 4 has no channel name",
            ),
            ("Timecode,BlendshapeCount,JawOpen\n", "cap.csv:0: no frames"),
            (
                "Timecode,BlendshapeCount,JawOpen\n\na,1,0.5,0.1\n",
                "cap.csv:3: 4 fields, the header has 3",
            ),
            (
                "Timecode,BlendshapeCount,JawOpen\na,1\n",
                "cap.csv:2: 2 fields, the header has 3",
            ),
            (
                "Timecode,BlendshapeCount,JawOpen\na,1,0.5\nb,1,wide\n",
                "cap.csv:3: JawOpen: `wide` is not a finite number",
            ),
            (
                "Timecode,BlendshapeCount,JawOpen\na,1,NaN\n",
                "cap.csv:2: JawOpen: `NaN` is not a finite number",
            ),
            (
                "Timecode,BlendshapeCount,JawOpen\na,x,0\n",
                "cap.csv:2: BlendshapeCount `x` is not a whole number",
            ),
            (
                "Timecode,BlendshapeCount,JawOpen\na,2,0\n",
                "cap.csv:2: BlendshapeCount says 2 channels, the header names 1",
            ),
        ];
        for (text, want) in cases {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.starts_with(want), "{text:?}: got {e:?}, want {want:?}");
        }
        let missing = Capture::read(Path::new("/nonexistent/cap.csv")).unwrap_err();
        assert!(
            missing
                .to_string()
                .starts_with("/nonexistent/cap.csv:0: cannot read")
        );
    }
}

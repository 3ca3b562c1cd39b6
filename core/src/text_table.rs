//! Whitespace-separated tables in text files with `#` comments: the expression targets
//! (`vertex dx dy dz`) and the ARKit basis (`name vertex dx dy dz`). Yields the data lines
//! with their 1-based numbers, and parses fields into values or a [`FieldProblem`] that
//! says what is wrong; each format wraps it in its own error with its file and line.

use glam::Vec3;

use crate::quote::quote;

/// One data line: its 1-based number and its fields.
#[derive(Debug, Clone, PartialEq)]
pub struct Row<'a> {
    pub line: usize,
    pub fields: Vec<&'a str>,
}

/// The lines of `text` that are neither blank nor `#` comments, split at whitespace.
pub fn rows(text: &str) -> impl Iterator<Item = Row<'_>> {
    text.lines().enumerate().filter_map(|(index, raw)| {
        let content = raw.trim();
        (!content.is_empty() && !content.starts_with('#')).then(|| Row {
            line: index + 1,
            fields: content.split_whitespace().collect(),
        })
    })
}

/// Why one field did not parse: the column's name, the text found and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct FieldProblem {
    pub field: &'static str,
    /// The text as found, quoted and cut by [`quote`].
    pub found: String,
    pub problem: &'static str,
}

impl FieldProblem {
    fn new(field: &'static str, found: &str, problem: &'static str) -> FieldProblem {
        FieldProblem {
            field,
            found: quote(found),
            problem,
        }
    }
}

/// A 0-based index; `problem` says of what when it is not one ("is not a vertex index").
pub fn index(field: &'static str, text: &str, problem: &'static str) -> Result<u32, FieldProblem> {
    text.parse().map_err(|_| FieldProblem::new(field, text, problem))
}

/// A finite number.
pub fn finite(field: &'static str, text: &str) -> Result<f32, FieldProblem> {
    let value: f32 = text
        .parse()
        .map_err(|_| FieldProblem::new(field, text, "is not a number"))?;
    if value.is_finite() {
        Ok(value)
    } else {
        Err(FieldProblem::new(field, text, "is not a finite number"))
    }
}

/// Three finite numbers, the columns named by `fields`.
pub fn vec3(fields: [&'static str; 3], texts: [&str; 3]) -> Result<Vec3, FieldProblem> {
    Ok(Vec3::new(
        finite(fields[0], texts[0])?,
        finite(fields[1], texts[1])?,
        finite(fields[2], texts[2])?,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_lines_keep_their_numbers() {
        let text = "# header\n\n  4 0.5 -1 2e-3 \n# more\n7\tx 1 1\n";
        let rows: Vec<Row> = rows(text).collect();
        assert_eq!(
            rows,
            [
                Row {
                    line: 3,
                    fields: vec!["4", "0.5", "-1", "2e-3"]
                },
                Row {
                    line: 5,
                    fields: vec!["7", "x", "1", "1"]
                },
            ]
        );
    }

    #[test]
    fn fields_say_what_is_wrong() {
        assert_eq!(index("vertex", "12", "is not a vertex index"), Ok(12));
        assert_eq!(
            index("vertex", "-1", "is not a vertex index"),
            Err(FieldProblem::new("vertex", "-1", "is not a vertex index"))
        );
        assert_eq!(
            vec3(["dx", "dy", "dz"], ["1", "2.5", "-3"]),
            Ok(Vec3::new(1.0, 2.5, -3.0))
        );
        assert_eq!(
            vec3(["dx", "dy", "dz"], ["1", "two", "3"]),
            Err(FieldProblem::new("dy", "two", "is not a number"))
        );
        assert_eq!(
            finite("dz", "inf"),
            Err(FieldProblem::new("dz", "inf", "is not a finite number"))
        );
    }
}

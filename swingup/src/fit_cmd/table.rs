//! The CSV tables `swingup fit` reads, and the typed errors of bad files
//! and arguments, each naming the file, line, row and column.

use std::fs;
use std::path::{Path, PathBuf};

/// A bad data file or bad arguments of `swingup fit`.
///
/// Lines count from 1 with the header on line 1 (blank lines are skipped but
/// counted); data rows count from 1 with the first row under the header;
/// columns count from 1.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FitError {
    /// The file could not be read.
    #[error("{file}: cannot read the file: {source}")]
    Io {
        /// The file.
        file: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file has no header row.
    #[error("{file}: the file is empty (expected a header row of column names, then rows of numbers)")]
    Empty {
        /// The file.
        file: PathBuf,
    },
    /// The file has a header but no data rows.
    #[error("{file}: no data rows under the header (line {line})")]
    NoRows {
        /// The file.
        file: PathBuf,
        /// Line of the header.
        line: usize,
    },
    /// An empty or repeated column name.
    #[error("{file}: header (line {line}), column {column}: {reason}")]
    BadHeader {
        /// The file.
        file: PathBuf,
        /// Line of the header.
        line: usize,
        /// Column number, from 1.
        column: usize,
        /// What is wrong.
        reason: String,
    },
    /// A row with more or fewer cells than the header has columns.
    #[error("{file}: line {line} (data row {row}) has {actual} cells but the header has {expected} columns ({detail})")]
    Ragged {
        /// The file.
        file: PathBuf,
        /// Line in the file.
        line: usize,
        /// Data row, from 1.
        row: usize,
        /// Number of columns of the header.
        expected: usize,
        /// Number of cells in the row.
        actual: usize,
        /// Which column is missing or extra.
        detail: String,
    },
    /// A cell that is not a number.
    #[error("{file}: line {line} (data row {row}), column {column} '{name}': {reason}")]
    BadCell {
        /// The file.
        file: PathBuf,
        /// Line in the file.
        line: usize,
        /// Data row, from 1.
        row: usize,
        /// Column number, from 1.
        column: usize,
        /// Column name.
        name: String,
        /// What is wrong with the cell.
        reason: String,
    },
    /// A column the command needs is not in the file.
    #[error("{file}: header (line {line}): no column '{name}' ({role}); the columns are {available}")]
    MissingColumn {
        /// The file.
        file: PathBuf,
        /// Line of the header.
        line: usize,
        /// The missing column.
        name: String,
        /// What the column is for ("target", "input").
        role: &'static str,
        /// The file's columns, comma-separated.
        available: String,
    },
    /// A test column that is neither an input nor a target of the training data.
    #[error("{file}: header (line {line}), column {column} '{name}': not a column of the training file {train}")]
    UnknownColumn {
        /// The test file.
        file: PathBuf,
        /// Line of the header.
        line: usize,
        /// Column number, from 1.
        column: usize,
        /// Column name.
        name: String,
        /// The training file.
        train: PathBuf,
    },
    /// An input that takes one value only: it cannot be normalised and the
    /// local fit could not use it.
    #[error("{file}: column {column} '{name}' is constant ({value}) over all rows; remove it")]
    ConstantInput {
        /// The file.
        file: PathBuf,
        /// Column number, from 1.
        column: usize,
        /// Column name.
        name: String,
        /// Its only value.
        value: f64,
    },
    /// Every training row is the same: nothing varies to regress on.
    #[error("{file}: all {rows} data rows are identical; a regression needs rows that differ")]
    IdenticalRows {
        /// The file.
        file: PathBuf,
        /// Its number of rows.
        rows: usize,
    },
    /// Fewer rows than the local polynomial has coefficients (plus one),
    /// or more coefficients than a local fit can hold.
    #[error(
        "{file}: a local {degree} fit in {inputs} inputs has {coefficients} coefficients; {reason}; \
         use a lower --degree or fewer input columns"
    )]
    ModelTooLarge {
        /// The training file.
        file: PathBuf,
        /// `constant`, `linear` or `quadratic`.
        degree: &'static str,
        /// Number of input columns.
        inputs: usize,
        /// Coefficients of one local fit.
        coefficients: usize,
        /// What does not fit: too few rows, or too many coefficients.
        reason: String,
    },
    /// A target that takes one value only: nothing to regress, and its
    /// normalised errors would divide by a zero variance.
    #[error("{file}: the target column {column} '{name}' is {value} in every row; there is nothing to regress")]
    ConstantTarget {
        /// The file.
        file: PathBuf,
        /// Column number, from 1.
        column: usize,
        /// Column name.
        name: String,
        /// Its only value.
        value: f64,
    },
    /// Every training column is a target.
    #[error("{file}: every column is a target; at least one input column is needed")]
    NoInputs {
        /// The file.
        file: PathBuf,
    },
    /// An argument outside its range.
    #[error("invalid argument {name}: {reason}")]
    InvalidArgument {
        /// The argument.
        name: &'static str,
        /// Why.
        reason: String,
    },
}

/// A numeric table read from a CSV file.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// The file it came from.
    pub file: PathBuf,
    /// Column names, from the header.
    pub names: Vec<String>,
    /// Rows of finite numbers, each as long as `names`.
    pub rows: Vec<Vec<f64>>,
    /// Line in the file of the header.
    pub header_line: usize,
    /// Line in the file of each row.
    pub lines: Vec<usize>,
}

impl Table {
    /// Reads a CSV file: a header row of distinct, nonempty column names,
    /// then at least one row of as many finite numbers, comma-separated,
    /// without quoting. Blank lines are skipped; cells are trimmed.
    pub fn read(path: &Path) -> Result<Self, FitError> {
        let text = fs::read_to_string(path).map_err(|source| FitError::Io {
            file: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// Parses CSV text as [`read`](Self::read) does; `file` names it in errors.
    pub fn parse(text: &str, file: &Path) -> Result<Self, FitError> {
        let file = file.to_path_buf();
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        let mut lines = text
            .lines()
            .enumerate()
            .map(|(i, l)| (i + 1, l))
            .filter(|(_, l)| !l.trim().is_empty());
        let Some((header_line, header)) = lines.next() else {
            return Err(FitError::Empty { file });
        };
        let names: Vec<String> = header.split(',').map(|s| s.trim().to_owned()).collect();
        for (j, name) in names.iter().enumerate() {
            let reason = if name.is_empty() {
                Some("empty column name".to_owned())
            } else if let Some(first) = names[..j].iter().position(|n| n == name) {
                Some(format!("column name '{name}' repeats column {}", first + 1))
            } else if name.parse::<f64>().is_ok() {
                Some(format!(
                    "'{name}' is a number: the first line must be a header of column names"
                ))
            } else {
                None
            };
            if let Some(reason) = reason {
                return Err(FitError::BadHeader {
                    file,
                    line: header_line,
                    column: j + 1,
                    reason,
                });
            }
        }
        let mut rows = Vec::new();
        let mut row_lines = Vec::new();
        for (row_index, (line, text)) in lines.enumerate() {
            let row = row_index + 1;
            let cells: Vec<&str> = text.split(',').map(str::trim).collect();
            if cells.len() != names.len() {
                let detail = if cells.len() < names.len() {
                    format!("column {} '{}' is missing", cells.len() + 1, names[cells.len()])
                } else {
                    format!("column {} is extra", names.len() + 1)
                };
                return Err(FitError::Ragged {
                    file,
                    line,
                    row,
                    expected: names.len(),
                    actual: cells.len(),
                    detail,
                });
            }
            let mut values = Vec::with_capacity(cells.len());
            for (j, cell) in cells.iter().enumerate() {
                let reason = match cell.parse::<f64>() {
                    _ if cell.is_empty() => Some("empty cell".to_owned()),
                    Ok(v) if v.is_finite() => {
                        values.push(v);
                        None
                    }
                    Ok(_) => Some(format!("'{cell}' is not a finite number")),
                    Err(_) => Some(format!("cannot read '{cell}' as a number")),
                };
                if let Some(reason) = reason {
                    return Err(FitError::BadCell {
                        file,
                        line,
                        row,
                        column: j + 1,
                        name: names[j].clone(),
                        reason,
                    });
                }
            }
            rows.push(values);
            row_lines.push(line);
        }
        if rows.is_empty() {
            return Err(FitError::NoRows {
                file,
                line: header_line,
            });
        }
        Ok(Self {
            file,
            names,
            rows,
            header_line,
            lines: row_lines,
        })
    }

    /// Index of the column `name`, or a [`FitError::MissingColumn`].
    pub(super) fn column(&self, name: &str, role: &'static str) -> Result<usize, FitError> {
        self.names
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| FitError::MissingColumn {
                file: self.file.clone(),
                line: self.header_line,
                name: name.to_owned(),
                role,
                available: self.names.join(", "),
            })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Table, FitError> {
        Table::parse(text, Path::new("t.csv"))
    }

    #[test]
    fn parses_plain_csv() {
        let t = parse("a, b\r\n1,2\n\n 3 ,4e-1\n").expect("valid");
        assert_eq!(t.names, ["a", "b"]);
        assert_eq!(t.rows, [vec![1.0, 2.0], vec![3.0, 0.4]]);
        assert_eq!(t.lines, [2, 4]);
    }

    #[test]
    fn names_line_row_and_column() {
        let e = parse("a,b\n1,2\n3,x\n").expect_err("bad cell").to_string();
        assert!(e.contains("line 3 (data row 2), column 2 'b'"), "{e}");
        let e = parse("a,b\n1,inf\n").expect_err("inf").to_string();
        assert!(e.contains("column 2 'b'") && e.contains("not a finite"), "{e}");
        let e = parse("a,b\n1\n").expect_err("short").to_string();
        assert!(
            e.contains("line 2 (data row 1)") && e.contains("column 2 'b' is missing"),
            "{e}"
        );
        assert!(matches!(parse(" \n"), Err(FitError::Empty { .. })));
        assert!(matches!(parse("a,b\n"), Err(FitError::NoRows { .. })));
        assert!(matches!(
            parse("a,a\n1,2\n"),
            Err(FitError::BadHeader { column: 2, .. })
        ));
        assert!(matches!(
            parse("1,2\n1,2\n"),
            Err(FitError::BadHeader { column: 1, .. })
        ));
        assert!(matches!(parse("a,\n1,2\n"), Err(FitError::BadHeader { column: 2, .. })));
    }
}

//! A CSV file's header and records with their line numbers, and column and
//! number look-ups whose errors name the file and line.

use crate::DatasetError;
use std::path::Path;

pub(crate) struct Table<'a> {
    pub path: &'a Path,
    pub headers: csv::StringRecord,
    pub records: Vec<(usize, csv::StringRecord)>,
}

impl<'a> Table<'a> {
    pub fn parse(text: &str, path: &'a Path) -> Result<Self, DatasetError> {
        let mut rdr = csv::ReaderBuilder::new().from_reader(text.as_bytes());
        let headers = rdr
            .headers()
            .map_err(|e| DatasetError::invalid(path, e.to_string()))?
            .clone();
        let mut records = Vec::new();
        for (i, rec) in rdr.records().enumerate() {
            let line = i + 2;
            records.push((
                line,
                rec.map_err(|e| DatasetError::invalid(path, format!("line {line}: {e}")))?,
            ));
        }
        Ok(Table {
            path,
            headers,
            records,
        })
    }

    /// Index of column `name`; `expected` is appended to the error (e.g.
    /// " (expected frame,x,y,source)").
    pub fn col(&self, name: &str, expected: &str) -> Result<usize, DatasetError> {
        self.headers
            .iter()
            .position(|h| h.trim() == name)
            .ok_or_else(|| {
                DatasetError::invalid(self.path, format!("missing column '{name}'{expected}"))
            })
    }

    pub fn optional_col(&self, name: &str) -> Option<usize> {
        self.headers.iter().position(|h| h.trim() == name)
    }

    pub fn number(
        &self,
        rec: &csv::StringRecord,
        line: usize,
        c: usize,
    ) -> Result<f64, DatasetError> {
        rec.get(c)
            .and_then(|s| s.trim().parse::<f64>().ok())
            .filter(|v| v.is_finite())
            .ok_or_else(|| {
                DatasetError::invalid(
                    self.path,
                    format!("line {line}: column {} is not a finite number", c + 1),
                )
            })
    }

    /// A number, or `None` where the field is empty.
    pub fn optional_number(
        &self,
        rec: &csv::StringRecord,
        line: usize,
        c: usize,
    ) -> Result<Option<f64>, DatasetError> {
        if rec.get(c).is_none_or(|s| s.trim().is_empty()) {
            return Ok(None);
        }
        self.number(rec, line, c).map(Some)
    }

    pub fn text<'r>(&self, rec: &'r csv::StringRecord, c: usize) -> &'r str {
        rec.get(c).unwrap_or("").trim()
    }
}

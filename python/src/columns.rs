//! Records as columns: each field of a record type (docs/interface.md) becomes one numpy
//! array, its name the field's, read off the records' serde form, so a field added to
//! the records is a column here with no second list. Integers are `int64`, numbers
//! `float64`; a column of integers or numbers with absent values is `float64` with NaN
//! where a value is absent (as pandas makes it); text is a list of `str` (or `None`).

use numpy::PyArray1;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use serde::Serialize;
use serde_json::Value;

/// `records` as a dict of columns; `template` (a record with every optional field
/// present that the run writes) names the columns when there is no record.
pub fn columns<'py, T: Serialize>(
    py: Python<'py>,
    template: &T,
    records: &[T],
) -> PyResult<Bound<'py, PyDict>> {
    let values: Vec<serde_json::Map<String, Value>> = records
        .iter()
        .map(|r| match serde_json::to_value(r) {
            Ok(Value::Object(map)) => Ok(map),
            Ok(_) => unreachable!("a record is a struct"),
            Err(e) => Err(pyo3::exceptions::PyValueError::new_err(e.to_string())),
        })
        .collect::<PyResult<_>>()?;
    let Value::Object(names) = serde_json::to_value(template)
        .map_err(|e| pyo3::exceptions::PyValueError::new_err(e.to_string()))?
    else {
        unreachable!("a record is a struct")
    };
    let out = PyDict::new(py);
    for (name, example) in names {
        let column: Vec<&Value> = values
            .iter()
            .map(|m| m.get(&name).unwrap_or(&Value::Null))
            .collect();
        out.set_item(&name, column_of(py, &column, &example)?)?;
    }
    Ok(out)
}

/// One column: numbers as an array, anything else as a list.
fn column_of<'py>(
    py: Python<'py>,
    column: &[&Value],
    example: &Value,
) -> PyResult<Bound<'py, PyAny>> {
    let numeric = |v: &&Value| v.is_number() || v.is_null();
    let all_null = column.iter().all(|v| v.is_null());
    let number_column = if all_null {
        // No value to tell: a numeric field (the template's) is a column of NaN.
        example.is_number() || example.is_null()
    } else {
        column.iter().all(numeric)
    };
    if number_column {
        let integers = !column.is_empty()
            && column
                .iter()
                .all(|v| v.as_i64().is_some() || v.as_u64().is_some());
        if integers {
            let v: Vec<i64> = column
                .iter()
                .map(|v| v.as_i64().unwrap_or(i64::MAX))
                .collect();
            return Ok(PyArray1::from_vec(py, v).into_any());
        }
        let v: Vec<f64> = column
            .iter()
            .map(|v| v.as_f64().unwrap_or(f64::NAN))
            .collect();
        return Ok(PyArray1::from_vec(py, v).into_any());
    }
    let list = PyList::empty(py);
    for v in column {
        list.append(pythonize::pythonize(py, *v)?)?;
    }
    Ok(list.into_any())
}

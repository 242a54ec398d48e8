//! Values and typed variables with the control's conversion rules: INT rounds on assignment, BOOL is 0/1,
//! arrays are row-major with their declared dimensions.

use std::fmt;

/// A value during evaluation. BOOL and INT are numbers; CHAR and STRING are text.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    Num(f64),
    Str(String),
}

impl Value {
    pub fn num(&self) -> Result<f64, String> {
        match self {
            Value::Num(v) => Ok(*v),
            Value::Str(s) => Err(format!("expected a number, found the string \"{s}\"")),
        }
    }

    pub fn truth(&self) -> Result<bool, String> {
        Ok(self.num()? != 0.0)
    }

    /// The text form used by `<<` and `WRITE`: integers without decimals, reals with up to six decimals.
    pub fn text(&self) -> String {
        match self {
            Value::Str(s) => s.clone(),
            Value::Num(v) => format_number(*v),
        }
    }
}

impl fmt::Display for Value {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.text())
    }
}

pub fn format_number(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        return format!("{v:.0}");
    }
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0');
    s.trim_end_matches('.').to_string()
}

/// A declared type (`DEF REAL`, PROC parameters).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VarType {
    Real,
    Int,
    Bool,
    Char,
    Str,
    /// An axis name (`DEF AXIS _X`), held as its upper-case text.
    Axis,
}

impl VarType {
    pub fn from_keyword(word: &str) -> Option<VarType> {
        Some(match word {
            "REAL" => VarType::Real,
            "INT" => VarType::Int,
            "BOOL" => VarType::Bool,
            "CHAR" => VarType::Char,
            "STRING" => VarType::Str,
            "AXIS" => VarType::Axis,
            _ => return None,
        })
    }

    fn default_value(self) -> Value {
        match self {
            VarType::Str | VarType::Axis => Value::Str(String::new()),
            VarType::Char => Value::Str("\0".into()),
            _ => Value::Num(0.0),
        }
    }

    /// Converts a value for storage in a variable of this type.
    pub fn convert(self, v: Value) -> Result<Value, String> {
        Ok(match (self, v) {
            (VarType::Real, Value::Num(x)) => Value::Num(x),
            // The control rounds to the nearest integer on assignment (.5 away from zero).
            (VarType::Int, Value::Num(x)) => Value::Num(x.round()),
            (VarType::Bool, Value::Num(x)) => Value::Num(if x != 0.0 { 1.0 } else { 0.0 }),
            // A CHAR holds one character; a number is taken as its code.
            (VarType::Char, Value::Num(x)) => match char::from_u32(x.round() as u32) {
                Some(c) if x >= 0.0 => Value::Str(c.to_string()),
                _ => return Err(format!("{x} is not a character code")),
            },
            (VarType::Char, Value::Str(s)) if s.chars().count() == 1 => Value::Str(s),
            (VarType::Char, Value::Str(s)) => {
                return Err(format!("\"{s}\" is not one character"));
            }
            (VarType::Str, v) => Value::Str(v.text()),
            (VarType::Axis, Value::Str(s)) => Value::Str(s.to_ascii_uppercase()),
            (VarType::Axis, Value::Num(x)) => {
                return Err(format!("an AXIS variable holds an axis name, not {x}"));
            }
            (_, Value::Str(s)) => {
                return Err(format!(
                    "cannot assign the string \"{s}\" to a numeric variable"
                ));
            }
        })
    }
}

/// A DEF variable or PROC parameter: a scalar (no dimensions) or an array.
#[derive(Debug, Clone)]
pub struct Variable {
    pub ty: VarType,
    pub dims: Vec<usize>,
    pub data: Vec<Value>,
}

impl Variable {
    pub fn new(ty: VarType, dims: Vec<usize>) -> Self {
        let len = dims.iter().product::<usize>().max(1);
        Variable {
            ty,
            dims,
            data: vec![ty.default_value(); len],
        }
    }

    /// Row-major position of `index` (empty for a scalar).
    pub fn offset(&self, index: &[usize]) -> Result<usize, String> {
        if index.len() != self.dims.len() {
            return Err(format!(
                "expected {} index value(s), found {}",
                self.dims.len(),
                index.len()
            ));
        }
        let mut at = 0;
        for (&i, &d) in index.iter().zip(&self.dims) {
            if i >= d {
                return Err(format!("index {i} out of range 0..{}", d - 1));
            }
            at = at * d + i;
        }
        Ok(at)
    }

    pub fn get(&self, index: &[usize]) -> Result<Value, String> {
        Ok(self.data[self.offset(index)?].clone())
    }

    pub fn set(&mut self, index: &[usize], v: Value) -> Result<(), String> {
        let at = self.offset(index)?;
        self.data[at] = self.ty.convert(v)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn int_rounds_and_bool_normalises_on_assignment() {
        let mut v = Variable::new(VarType::Int, vec![]);
        v.set(&[], Value::Num(2.5)).unwrap();
        assert_eq!(v.get(&[]).unwrap(), Value::Num(3.0));
        v.set(&[], Value::Num(-2.4)).unwrap();
        assert_eq!(v.get(&[]).unwrap(), Value::Num(-2.0));
        let mut c = Variable::new(VarType::Char, vec![]);
        c.set(&[], Value::Num(65.0)).unwrap();
        assert_eq!(c.get(&[]).unwrap(), Value::Str("A".into()));
        assert!(c.set(&[], Value::Str("AB".into())).is_err());
        let mut b = Variable::new(VarType::Bool, vec![]);
        b.set(&[], Value::Num(-7.0)).unwrap();
        assert_eq!(b.get(&[]).unwrap(), Value::Num(1.0));
    }

    #[test]
    fn arrays_are_row_major_and_bounds_checked() {
        let mut a = Variable::new(VarType::Real, vec![2, 3]);
        a.set(&[1, 2], Value::Num(5.0)).unwrap();
        assert_eq!(a.data[5], Value::Num(5.0));
        assert!(a.get(&[2, 0]).is_err());
        assert!(a.get(&[1]).is_err());
    }

    #[test]
    fn numbers_print_without_trailing_zeros() {
        assert_eq!(format_number(3.0), "3");
        assert_eq!(format_number(0.1 + 0.2), "0.3");
        assert_eq!(format_number(-1.25), "-1.25");
    }
}

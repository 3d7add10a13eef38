//! Probability fields and vector fields (thesis §5.1, §5.3.7): greyscale maps in UV space read as
//! densities per unit surface area (fixing the per-texel bias the thesis notes, by weighting
//! with texel area), RGB maps read as vectors, and a small expression language to composite
//! them (thesis §7.5).

use crate::{Result, SkinError};
use derma_core::image_io;
use derma_core::progress::{Note, Progress};
use derma_core::Map;
use std::collections::BTreeMap;
use std::path::Path;

/// A named set of scalar fields and vector fields, all in UV space.
#[derive(Default, Clone)]
pub struct FieldSet {
    /// Scalar (probability) fields by name.
    pub scalars: BTreeMap<String, Map>,
    /// Vector fields: direction (R, G in [0,1], 0.5 = zero) and length B.
    pub vectors: BTreeMap<String, [Map; 3]>,
    /// Where each field came from: "built-in", "uniform", the file read or "= expression"
    /// (the report lists it, so a field left at a default is never silent).
    pub origins: BTreeMap<String, String>,
}

/// A vector read from a vector field: a unit direction in UV space and a length in [0, 1].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvVector {
    /// Unit direction in UV space (zero where the field has none).
    pub dir: glam::Vec2,
    /// Length in [0, 1].
    pub length: f32,
}

impl FieldSet {
    /// The scalar field `name`; the error lists the known ones.
    pub fn scalar(&self, name: &str) -> Result<&Map> {
        self.scalars.get(name).ok_or_else(|| SkinError::Field {
            name: name.into(),
            detail: format!(
                "no such field; known fields: {}",
                self.scalars.keys().cloned().collect::<Vec<_>>().join(", ")
            ),
        })
    }

    /// Vector at (u, v) of vector field `name`.
    pub fn vector(&self, name: &str, u: f32, v: f32, wrap: bool) -> Result<UvVector> {
        let f = self.vectors.get(name).ok_or_else(|| SkinError::Field {
            name: name.into(),
            detail: "no such vector field".into(),
        })?;
        Ok(decode_vector(f, u, v, wrap))
    }
}

/// The vector at (u, v) of a vector field's three maps (direction R, G with 0.5 = 0; length B).
#[inline]
pub fn decode_vector(f: &[Map; 3], u: f32, v: f32, wrap: bool) -> UvVector {
    let (w, h) = (f[0].width(), f[0].height());
    decode_vector_at(f, &derma_core::map::Taps::uv(w, h, u, v, wrap))
}

/// [`decode_vector`] at the point of `taps`.
#[inline]
pub fn decode_vector_at(f: &[Map; 3], taps: &derma_core::map::Taps) -> UvVector {
    let x = 2.0 * f[0].sample(taps) - 1.0;
    let y = 2.0 * f[1].sample(taps) - 1.0;
    let d = glam::Vec2::new(x, y);
    if d.length() < ZERO_VECTOR {
        return UvVector {
            dir: glam::Vec2::ZERO,
            length: 0.0,
        };
    }
    UvVector {
        dir: d.normalize(),
        length: f[2].sample(taps).clamp(0.0, 1.0),
    }
}

/// Encoded directions shorter than this are zero: 0.5 (the encoding's zero) is not a code of
/// an 8- or 16-bit image, so a painted or exported zero reads back as a short diagonal
/// (|d| ≤ √2/255 in 8 bits), which must not become a direction.
pub const ZERO_VECTOR: f32 = 1.0 / 127.0;

/// True when `path` names an OpenEXR file (by its extension).
fn is_exr(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

impl FieldSet {
    /// Loads every `NAME.png`/`NAME.exr` of `dir` as field NAME (`*_vectors` files as vector
    /// fields) and returns the names read. A name that is not `known` (a misspelt file would
    /// otherwise be ignored) and a name given twice (PNG and EXR) are errors naming the file;
    /// suspicious inputs (colour, out of range) are noted on `progress`.
    pub fn load_dir(
        &mut self,
        dir: &Path,
        known: &std::collections::BTreeSet<String>,
        progress: &dyn Progress,
    ) -> Result<Vec<String>> {
        let entries = std::fs::read_dir(dir).map_err(|source| derma_core::CoreError::Read {
            path: dir.to_path_buf(),
            source,
        })?;
        let mut paths: Vec<_> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
        paths.sort();
        let mut read: BTreeMap<String, std::path::PathBuf> = BTreeMap::new();
        for p in paths {
            let ext = p
                .extension()
                .map(|e| e.to_string_lossy().to_ascii_lowercase())
                .unwrap_or_default();
            if ext != "png" && ext != "exr" {
                continue;
            }
            let name = p
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            if !known.contains(&name) {
                return Err(SkinError::Input {
                    path: p,
                    detail: format!(
                        "'{name}' is not a field derma reads; known fields: {}",
                        known.iter().cloned().collect::<Vec<_>>().join(", ")
                    ),
                });
            }
            if let Some(first) = read.get(&name) {
                return Err(SkinError::Input {
                    path: p.clone(),
                    detail: format!(
                        "field '{name}' is given twice (also '{}'); keep one",
                        first.display()
                    ),
                });
            }
            self.load_file(&name, &p, progress)?;
            read.insert(name, p);
        }
        Ok(read.into_keys().collect())
    }

    /// Loads one file as field `name`.
    pub fn load_file(&mut self, name: &str, path: &Path, progress: &dyn Progress) -> Result<()> {
        if name.ends_with("_vectors") {
            let img = image_io::read_rgb(path)?;
            if !img.is_color {
                progress.note(Note::warning(format!(
                    "vector field '{name}' ({}) is greyscale (R = G = B); expected RGB: R, G the direction (0.5 = 0) and B the length",
                    path.display()
                )));
            }
            let [r, g, b]: [Map; 3] = img.channels.try_into().map_err(|_| SkinError::Field {
                name: name.into(),
                detail: "expected RGB".into(),
            })?;
            self.vectors.insert(name.into(), [r, g, b]);
            self.origins.insert(name.into(), path.display().to_string());
        } else {
            let img = image_io::read_grey(path)?;
            if img.is_color {
                progress.note(Note::warning(format!(
                    "field '{name}' ({}) is a colour image; converted to greyscale by luminance (paint probability fields in grey)",
                    path.display()
                )));
            }
            let mut m = img.channels.into_iter().next().expect("one channel");
            if crate::regional::CHANNELS.contains(&name) {
                // Regional gains and shifts: their own values in EXR, encoded in [0, 1] in
                // 8/16-bit images (regional::decode_png).
                if !is_exr(path) {
                    m = m.map(|v| crate::regional::decode_png(name, v).unwrap_or(v));
                }
            } else if m.data().iter().any(|&v| !(0.0..=1.0).contains(&v)) {
                progress.note(Note::warning(format!(
                    "field '{name}' ({}) has values outside [0, 1]; clamped",
                    path.display()
                )));
            }
            self.scalars.insert(name.into(), m);
            self.origins.insert(name.into(), path.display().to_string());
        }
        Ok(())
    }

    /// Defines field `name` by an expression over existing fields (e.g. "face - eyes - lips").
    pub fn define(&mut self, name: &str, expr: &str) -> Result<()> {
        if expr.len() > MAX_EXPRESSION_LEN {
            return Err(SkinError::Field {
                name: name.into(),
                detail: format!(
                    "the expression is {} characters long; at most {MAX_EXPRESSION_LEN} are read",
                    expr.len()
                ),
            });
        }
        let ast = Parser::new(expr)
            .parse()
            .map_err(|detail| SkinError::Field {
                name: name.into(),
                detail: format!("in expression \"{expr}\": {detail}"),
            })?;
        let mut refs = Vec::new();
        ast.names(&mut refs);
        let mut size = (1usize, 1usize);
        for r in &refs {
            let m = self.scalars.get(r).ok_or_else(|| SkinError::Field {
                name: name.into(),
                detail: format!("expression \"{expr}\" uses unknown field '{r}'"),
            })?;
            if m.width() * m.height() > size.0 * size.1 {
                size = (m.width(), m.height());
            }
        }
        let resampled: BTreeMap<&str, Map> = refs
            .iter()
            .map(|r| (r.as_str(), self.scalars[r].resized(size.0, size.1)))
            .collect();
        let data: Vec<f32> = (0..size.0 * size.1)
            .map(|i| ast.eval(&|n| resampled[n].data()[i]).clamp(0.0, 1.0))
            .collect();
        self.scalars
            .insert(name.into(), Map::from_vec(size.0, size.1, data)?);
        self.origins.insert(name.into(), format!("= {expr}"));
        Ok(())
    }
}

/// The field names an expression reads (none when it does not parse; [`FieldSet::define`]
/// reports that).
pub fn expression_names(expr: &str) -> Vec<String> {
    let mut out = Vec::new();
    if let Ok(ast) = Parser::new(expr).parse() {
        ast.names(&mut out);
    }
    out
}

/// Expression tree of the compositing language.
#[derive(Debug, Clone)]
enum Expr {
    Num(f32),
    Name(String),
    Neg(Box<Expr>),
    Bin(char, Box<Expr>, Box<Expr>),
    Call(String, Vec<Expr>),
}

impl Expr {
    fn names(&self, out: &mut Vec<String>) {
        match self {
            Expr::Num(_) => {}
            Expr::Name(n) => {
                if !out.contains(n) {
                    out.push(n.clone())
                }
            }
            Expr::Neg(e) => e.names(out),
            Expr::Bin(_, a, b) => {
                a.names(out);
                b.names(out)
            }
            Expr::Call(_, args) => args.iter().for_each(|a| a.names(out)),
        }
    }

    fn eval(&self, get: &dyn Fn(&str) -> f32) -> f32 {
        match self {
            Expr::Num(v) => *v,
            Expr::Name(n) => get(n),
            Expr::Neg(e) => -e.eval(get),
            Expr::Bin(op, a, b) => {
                let (a, b) = (a.eval(get), b.eval(get));
                match op {
                    '+' => a + b,
                    '-' => a - b,
                    '*' => a * b,
                    _ => a / b.max(1e-6),
                }
            }
            Expr::Call(f, args) => {
                let v: Vec<f32> = args.iter().map(|a| a.eval(get)).collect();
                match f.as_str() {
                    "min" => v[0].min(v[1]),
                    "max" => v[0].max(v[1]),
                    "clamp" => v[0].clamp(0.0, 1.0),
                    "pow" => v[0].max(0.0).powf(v[1]),
                    // smooth(x, a, b): smoothstep of x between a and b
                    _ => {
                        let t = ((v[0] - v[1]) / (v[2] - v[1])).clamp(0.0, 1.0);
                        t * t * (3.0 - 2.0 * t)
                    }
                }
            }
        }
    }
}

/// Longest expression read (its tree's depth, and so the evaluation's recursion, stays small).
const MAX_EXPRESSION_LEN: usize = 1000;
/// Deepest nesting of parentheses, signs and calls.
const MAX_NESTING: usize = 64;

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
    depth: usize,
}

impl<'a> Parser<'a> {
    fn new(s: &'a str) -> Self {
        Self {
            s: s.as_bytes(),
            i: 0,
            depth: 0,
        }
    }
    fn ws(&mut self) {
        while self.i < self.s.len() && self.s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
    }
    fn peek(&mut self) -> Option<u8> {
        self.ws();
        self.s.get(self.i).copied()
    }
    fn parse(mut self) -> std::result::Result<Expr, String> {
        let e = self.sum()?;
        match self.peek() {
            None => Ok(e),
            Some(c) => Err(format!(
                "unexpected '{}' at position {}",
                c as char,
                self.i + 1
            )),
        }
    }
    fn sum(&mut self) -> std::result::Result<Expr, String> {
        let mut e = self.product()?;
        while let Some(c @ (b'+' | b'-')) = self.peek() {
            self.i += 1;
            e = Expr::Bin(c as char, Box::new(e), Box::new(self.product()?));
        }
        Ok(e)
    }
    fn product(&mut self) -> std::result::Result<Expr, String> {
        let mut e = self.unary()?;
        while let Some(c @ (b'*' | b'/')) = self.peek() {
            self.i += 1;
            e = Expr::Bin(c as char, Box::new(e), Box::new(self.unary()?));
        }
        Ok(e)
    }
    fn unary(&mut self) -> std::result::Result<Expr, String> {
        self.depth += 1;
        if self.depth > MAX_NESTING {
            return Err(format!("nested more than {MAX_NESTING} deep"));
        }
        let e = self.atom();
        self.depth -= 1;
        e
    }
    fn atom(&mut self) -> std::result::Result<Expr, String> {
        match self.peek() {
            Some(b'-') => {
                self.i += 1;
                Ok(Expr::Neg(Box::new(self.unary()?)))
            }
            Some(b'(') => {
                self.i += 1;
                let e = self.sum()?;
                if self.peek() != Some(b')') {
                    return Err("missing ')'".into());
                }
                self.i += 1;
                Ok(e)
            }
            Some(c) if c.is_ascii_digit() || c == b'.' => {
                let start = self.i;
                while self.i < self.s.len()
                    && (self.s[self.i].is_ascii_digit() || self.s[self.i] == b'.')
                {
                    self.i += 1;
                }
                let t = std::str::from_utf8(&self.s[start..self.i]).unwrap_or("");
                t.parse()
                    .map(Expr::Num)
                    .map_err(|_| format!("bad number '{t}'"))
            }
            Some(c) if c.is_ascii_alphabetic() || c == b'_' => {
                let start = self.i;
                while self.i < self.s.len()
                    && (self.s[self.i].is_ascii_alphanumeric() || self.s[self.i] == b'_')
                {
                    self.i += 1;
                }
                let name = String::from_utf8_lossy(&self.s[start..self.i]).into_owned();
                if self.peek() == Some(b'(') {
                    self.i += 1;
                    let mut args = vec![self.sum()?];
                    while self.peek() == Some(b',') {
                        self.i += 1;
                        args.push(self.sum()?);
                    }
                    if self.peek() != Some(b')') {
                        return Err(format!("missing ')' after arguments of {name}"));
                    }
                    self.i += 1;
                    let arity = match name.as_str() {
                        "min" | "max" | "pow" => 2,
                        "clamp" => 1,
                        "smooth" => 3,
                        _ => {
                            return Err(format!(
                                "unknown function '{name}' (known: min, max, clamp, pow, smooth)"
                            ))
                        }
                    };
                    if args.len() != arity {
                        return Err(format!(
                            "{name} takes {arity} argument(s), got {}",
                            args.len()
                        ));
                    }
                    Ok(Expr::Call(name, args))
                } else {
                    Ok(Expr::Name(name))
                }
            }
            Some(c) => Err(format!(
                "unexpected '{}' at position {}",
                c as char,
                self.i + 1
            )),
            None => Err("unexpected end of expression".into()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The encoding's zero read back from 8- and 16-bit files is no direction (before: the
    /// 16-bit code nearest 0.5 read as a diagonal, turning the relief's furrows at the seams
    /// of the exported tension field); a short painted direction stays one.
    #[test]
    fn a_quantised_zero_vector_has_no_direction() {
        use derma_core::image_io::{dequantize16, quantize16};
        let field = |r: f32, g: f32| {
            [
                Map::filled(2, 2, r),
                Map::filled(2, 2, g),
                Map::filled(2, 2, 1.0),
            ]
        };
        let z16 = dequantize16(quantize16(0.5));
        let z8 = 128.0 / 255.0;
        for z in [z16, z8] {
            let v = decode_vector(&field(z, z), 0.5, 0.5, false);
            assert_eq!((v.dir, v.length), (glam::Vec2::ZERO, 0.0), "{z}");
        }
        let v = decode_vector(&field(0.52, 0.5), 0.5, 0.5, false);
        assert!(
            (v.dir - glam::Vec2::X).length() < 1e-3 && v.length == 1.0,
            "{v:?}"
        );
    }

    #[test]
    fn expressions_composite_fields() {
        let mut f = FieldSet::default();
        f.scalars.insert("face".into(), Map::filled(4, 4, 0.9));
        f.scalars.insert(
            "eyes".into(),
            Map::from_vec(2, 2, vec![0.5, 0.0, 0.0, 0.0]).unwrap(),
        );
        f.define("freckles", "face - eyes * 2").unwrap();
        let m = &f.scalars["freckles"];
        assert_eq!((m.width(), m.height()), (4, 4));
        assert!((m.get(3, 3) - 0.9).abs() < 1e-6);
        assert_eq!(m.get(0, 0), 0.0); // 0.9 − 1.0 clamped
        f.define("p", "pow(face, 2) + min(0.05, max(eyes, 0.01))")
            .unwrap();
        assert!((f.scalars["p"].get(3, 3) - (0.81 + 0.01)).abs() < 1e-5);
        f.define("s", "smooth(face, 0.8, 1.0)").unwrap();
        assert!((f.scalars["s"].get(1, 1) - 0.5).abs() < 1e-5);
    }

    #[test]
    fn expression_errors_name_the_problem() {
        let mut f = FieldSet::default();
        f.scalars.insert("face".into(), Map::filled(2, 2, 1.0));
        let e = f.define("x", "face - nose").unwrap_err().to_string();
        assert!(e.contains("nose") && e.contains("'x'"), "{e}");
        assert!(f.define("x", "face -").is_err());
        assert!(f
            .define("x", "foo(face)")
            .unwrap_err()
            .to_string()
            .contains("unknown function"));
        assert!(f
            .define("x", "min(face)")
            .unwrap_err()
            .to_string()
            .contains("2 argument"));
    }
}

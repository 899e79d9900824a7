//! Setting a scenario field by its path on the TOML document (`controller.nn.k1`,
//! `arms[0].links[1].mass`, `sensors.force.std_dev`), before the document goes through the normal
//! scenario loader (so validation and messages are the scenario's own).
//!
//! `object.mass` is the object's mass on every document. A spatial object and a planar object in
//! the form with a mass (`mass`, rotational `inertia`) have it as a field, and the loader derives
//! the rest (the uniform box's inertia unless given, the gravity wrench from the plant's gravity).
//! A planar object in the explicit form (`inertia = [m, m, I]` and `gravity = (0, m g, 0)`, the
//! paper's matrices) has no `mass` key: setting it writes both translational inertias and scales
//! the gravity wrench by the mass ratio, so every quantity that depends on the mass changes
//! together (the controller's model is built from the same object, so it changes too).

use toml::{Table, Value};

use crate::scenario::Kind;

/// Fields computed from others; see the module documentation.
pub const DERIVED: &[(&str, &str)] = &[(
    "object.mass",
    "the object's mass: on an explicit planar object (inertia = [m, m, I], gravity) it sets \
     object.inertia[0] and [1] and scales object.gravity by the mass ratio",
)];

/// A path segment: a key or an array index.
#[derive(Clone, Debug, PartialEq)]
pub enum Seg {
    /// A table key.
    Key(String),
    /// An array index.
    Index(usize),
}

/// Split `a.b[1].c` into segments; an error describes a malformed path.
pub fn segments(path: &str) -> Result<Vec<Seg>, String> {
    let mut out = Vec::new();
    if path.trim().is_empty() {
        return Err("the field path is empty".into());
    }
    for part in path.split('.') {
        if part.is_empty() {
            return Err(format!("`{path}` has an empty segment"));
        }
        let (key, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        if key.is_empty() {
            return Err(format!("`{path}`: an index must follow a field name"));
        }
        out.push(Seg::Key(key.to_string()));
        while !rest.is_empty() {
            let Some(inner) = rest.strip_prefix('[') else {
                return Err(format!("`{path}`: unexpected `{rest}`"));
            };
            let Some(end) = inner.find(']') else {
                return Err(format!("`{path}`: unclosed `[`"));
            };
            let k: usize = inner[..end]
                .trim()
                .parse()
                .map_err(|_| format!("`{path}`: `{}` is not an index", &inner[..end]))?;
            out.push(Seg::Index(k));
            rest = &inner[end + 1..];
        }
    }
    Ok(out)
}

/// Set `value` at `path` in `doc`, creating missing tables on the way (the loader then rejects
/// keys the scenario does not have). Array elements must exist.
pub fn set(doc: &mut Table, path: &str, value: Value) -> Result<(), String> {
    if path == "object.mass" && Kind::of(doc) == Kind::Planar {
        return set_mass(doc, value);
    }
    let segs = segments(path)?;
    let mut cur: &mut Value = {
        let Some(Seg::Key(first)) = segs.first() else {
            return Err(format!("`{path}` must start with a field name"));
        };
        if segs.len() == 1 {
            doc.insert(first.clone(), value);
            return Ok(());
        }
        doc.entry(first.clone())
            .or_insert_with(|| Value::Table(Table::new()))
    };
    let mut done = String::new();
    for (i, seg) in segs.iter().enumerate() {
        if i > 0 {
            let last = i + 1 == segs.len();
            cur = match (seg, cur) {
                (Seg::Key(k), Value::Table(t)) => {
                    if last {
                        t.insert(k.clone(), value);
                        return Ok(());
                    }
                    t.entry(k.clone())
                        .or_insert_with(|| Value::Table(Table::new()))
                }
                (Seg::Key(k), _) => {
                    return Err(format!("{done} is not a table, so it has no field `{k}`"));
                }
                (Seg::Index(n), Value::Array(a)) => {
                    let len = a.len();
                    let Some(slot) = a.get_mut(*n) else {
                        return Err(format!("{done} has {len} entries, so it has no index {n}"));
                    };
                    if last {
                        *slot = value;
                        return Ok(());
                    }
                    slot
                }
                (Seg::Index(n), _) => {
                    return Err(format!(
                        "{done} is not an array in the base scenario, so it has no index {n} \
                         (vary the whole field with a grid or a choice of arrays)"
                    ));
                }
            };
        }
        match seg {
            Seg::Key(k) if done.is_empty() => done.push_str(k),
            Seg::Key(k) => {
                done.push('.');
                done.push_str(k);
            }
            Seg::Index(n) => done.push_str(&format!("[{n}]")),
        }
    }
    Ok(())
}

fn as_f64(v: &Value) -> Option<f64> {
    match v {
        Value::Float(x) => Some(*x),
        Value::Integer(i) => Some(*i as f64),
        _ => None,
    }
}

/// `object.mass = m`: `inertia[0] = inertia[1] = m`, `gravity *= m / m_base`.
fn set_mass(doc: &mut Table, value: Value) -> Result<(), String> {
    let m = as_f64(&value).ok_or_else(|| "object.mass takes a number (kg)".to_string())?;
    let obj = doc
        .get_mut("object")
        .and_then(Value::as_table_mut)
        .ok_or("the base scenario has no [object] table")?;
    if obj.contains_key("mass") {
        // The form with a mass: the loader derives M_o and G_o from it.
        obj.insert("mass".into(), Value::Float(m));
        return Ok(());
    }
    let inertia = obj
        .get("inertia")
        .and_then(Value::as_array)
        .and_then(|a| a.iter().map(as_f64).collect::<Option<Vec<f64>>>())
        .filter(|a| a.len() == 3)
        .ok_or("the base scenario's object.inertia is not three numbers")?;
    if inertia[0] != inertia[1] {
        return Err(format!(
            "the base scenario's object has different x and y masses (inertia = [{}, {}, …]); \
             vary object.inertia and object.gravity instead",
            inertia[0], inertia[1]
        ));
    }
    let m0 = inertia[0];
    if let Some(g) = obj.get_mut("gravity").and_then(Value::as_array_mut) {
        for x in g.iter_mut() {
            if let Some(v) = as_f64(x) {
                *x = Value::Float(if m0 != 0.0 { v * m / m0 } else { v });
            }
        }
    }
    obj.insert(
        "inertia".into(),
        Value::Array(vec![
            Value::Float(m),
            Value::Float(m),
            Value::Float(inertia[2]),
        ]),
    );
    Ok(())
}

/// Every field path of a TOML document (tables descended, arrays of tables indexed, other arrays
/// listed whole and by index), for "did you mean" suggestions.
pub fn all_paths(doc: &Table) -> Vec<String> {
    fn walk(prefix: &str, v: &Value, out: &mut Vec<String>) {
        match v {
            Value::Table(t) => {
                for (k, v) in t {
                    let p = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    out.push(p.clone());
                    walk(&p, v, out);
                }
            }
            Value::Array(a) => {
                for (i, v) in a.iter().enumerate() {
                    let p = format!("{prefix}[{i}]");
                    out.push(p.clone());
                    walk(&p, v, out);
                }
            }
            _ => {}
        }
    }
    let mut out = Vec::new();
    walk("", &Value::Table(doc.clone()), &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paths_parse_and_set() {
        assert_eq!(
            segments("arms[0].links[1].mass").unwrap(),
            vec![
                Seg::Key("arms".into()),
                Seg::Index(0),
                Seg::Key("links".into()),
                Seg::Index(1),
                Seg::Key("mass".into())
            ]
        );
        assert!(segments("a..b").is_err());
        assert!(segments("a[x]").is_err());
        let mut doc: Table = toml::from_str(
            "[object]\ninertia = [1.0, 1.0, 0.5]\ngravity = [0.0, 9.8, 0.0]\n[[arms]]\nx = [1, 2]\n",
        )
        .unwrap();
        set(&mut doc, "controller.nn.k1", Value::Integer(3)).unwrap();
        assert_eq!(doc["controller"]["nn"]["k1"].as_integer(), Some(3));
        set(&mut doc, "arms[0].x[1]", Value::Integer(7)).unwrap();
        assert_eq!(doc["arms"][0]["x"][1].as_integer(), Some(7));
        assert!(set(&mut doc, "arms[3].x", Value::Integer(7)).is_err());
        set(&mut doc, "object.mass", Value::Float(2.0)).unwrap();
        assert_eq!(doc["object"]["inertia"][1].as_float(), Some(2.0));
        assert_eq!(doc["object"]["inertia"][2].as_float(), Some(0.5));
        assert_eq!(doc["object"]["gravity"][1].as_float(), Some(19.6));
        // On a spatial document object.mass is a plain field.
        let mut doc: Table = toml::from_str(
            "[[arms]]\nmodel = \"ur5\"\n[object]\nsize = [0.4, 0.2, 0.2]\nmass = 3.0\n",
        )
        .unwrap();
        assert_eq!(Kind::of(&doc), Kind::Spatial);
        set(&mut doc, "object.mass", Value::Float(4.5)).unwrap();
        assert_eq!(doc["object"]["mass"].as_float(), Some(4.5));
        assert!(doc["object"].get("inertia").is_none());
    }

    #[test]
    fn object_mass_is_a_plain_field_of_a_planar_object_with_a_mass() {
        let mut doc: Table = toml::from_str(
            "[[arms]]\nbase = [0.0, 0.0]\n[object]\nmass = 1.0\ninertia = 0.5\ndamping = [1.0, 1.0, 1.0]\n",
        )
        .unwrap();
        set(&mut doc, "object.mass", Value::Float(2.5)).unwrap();
        assert_eq!(doc["object"]["mass"].as_float(), Some(2.5));
        assert_eq!(doc["object"]["inertia"].as_float(), Some(0.5));
        assert!(doc["object"].get("gravity").is_none());
    }
}

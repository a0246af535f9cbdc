//! The parameter reference (the book's `reference/parameters-generated.md`): every `[base]` key
//! with its type, default and the doc comment of its field in the code — the code's own
//! documentation, so that a new parameter cannot be missing from the book. Built from the
//! parameter structs' JSON schema (schemars: doc comments, serde's names, nested tables, enums)
//! and from `Params::default()` for the defaults. Formats only.

use crate::params::Params;
use schemars::schema::{InstanceType, RootSchema, Schema, SchemaObject, SingleOrVec};

/// The reference as Markdown: one section per `[base]` table, one row per key (nested tables as
/// dotted keys), in declaration order.
pub fn markdown() -> String {
    let root = schemars::schema_for!(Params);
    let defaults = toml::Value::Table(Params::default().to_table());
    let mut out = String::new();
    let Some(sections) = root.schema.object.as_ref() else { return out };
    for (section, schema) in &sections.properties {
        let description = describe(schema);
        out.push_str(&format!("## `[base.{section}]`\n\n"));
        if !description.is_empty() {
            out.push_str(&format!("{description}\n\n"));
        }
        let mut rows = Vec::new();
        let default = defaults.get(section.as_str());
        keys(&root, resolve(&root, schema), "", default, &mut rows);
        if rows.is_empty() {
            out.push_str("(no keys)\n\n");
            continue;
        }
        out.push_str("| key | type | default | what it is |\n|---|---|---|---|\n");
        for row in rows {
            out.push_str(&format!(
                "| `{}` | {} | {} | {} |\n",
                row.key,
                cell(&row.kind),
                row.default.map_or("—".into(), |d| format!("`{}`", cell(&d))),
                cell(&row.doc)
            ));
        }
        out.push('\n');
    }
    out
}

struct Row {
    key: String,
    kind: String,
    default: Option<String>,
    doc: String,
}

/// The rows of the keys of `schema` (an object, or an enum tagged by one of its keys), under
/// `prefix`, with defaults from `default`.
fn keys(
    root: &RootSchema,
    schema: &SchemaObject,
    prefix: &str,
    default: Option<&toml::Value>,
    rows: &mut Vec<Row>,
) {
    // an internally tagged enum (`model = "…"`): its tag, then each variant's own keys
    if let Some(variants) = schema.subschemas.as_ref().and_then(|s| s.one_of.as_ref()) {
        let mut seen: Vec<String> = Vec::new();
        for variant in variants {
            let variant = resolve(root, variant);
            if let Some(obj) = variant.object.as_ref() {
                for (name, prop) in &obj.properties {
                    let prop = resolve(root, prop);
                    let key = format!("{prefix}{name}");
                    if seen.contains(&key) {
                        continue;
                    }
                    seen.push(key.clone());
                    let tag = prop.enum_values.as_ref().filter(|v| v.len() == 1);
                    let (kind, doc) = match tag {
                        // the tag: every variant's value with the variant's doc
                        Some(_) => (
                            "one of: ".to_string() + &tag_values(root, variants, name).join(", "),
                            describe_object(schema),
                        ),
                        None => (kind_of(root, prop), describe_prop(obj.properties.get(name))),
                    };
                    let value = default.and_then(|d| d.get(name.as_str()));
                    rows.push(Row { key, kind, default: value.map(show), doc });
                }
            }
        }
        return;
    }
    let Some(obj) = schema.object.as_ref() else { return };
    for (name, prop) in &obj.properties {
        let target = resolve(root, prop);
        let value = default.and_then(|d| d.get(name.as_str()));
        let nested = target.object.as_ref().is_some_and(|o| !o.properties.is_empty())
            || target.subschemas.as_ref().is_some_and(|s| {
                s.one_of
                    .as_ref()
                    .is_some_and(|v| v.iter().any(|v| resolve(root, v).object.is_some()))
            });
        if nested {
            keys(root, target, &format!("{prefix}{name}."), value, rows);
            continue;
        }
        rows.push(Row {
            key: format!("{prefix}{name}"),
            kind: kind_of(root, target),
            default: value.map(show),
            doc: describe_prop(Some(prop)),
        });
    }
}

/// The values of tag `name` across `variants`, each with its variant's doc.
fn tag_values(root: &RootSchema, variants: &[Schema], name: &str) -> Vec<String> {
    variants
        .iter()
        .filter_map(|v| {
            let v = resolve(root, v);
            let tag = resolve(root, v.object.as_ref()?.properties.get(name)?);
            let value = tag.enum_values.as_ref()?.first()?.as_str()?.to_string();
            let doc = describe_object(v);
            Some(if doc.is_empty() { format!("`{value}`") } else { format!("`{value}` ({doc})") })
        })
        .collect()
}

/// What kind of value a key takes: a JSON type, or the list of an enum's values.
fn kind_of(root: &RootSchema, schema: &SchemaObject) -> String {
    if let Some(values) = &schema.enum_values {
        let values: Vec<String> =
            values.iter().map(|v| format!("`{}`", v.as_str().unwrap_or("?"))).collect();
        return format!("one of: {}", values.join(", "));
    }
    if let Some(variants) =
        schema.subschemas.as_ref().and_then(|s| s.one_of.as_ref().or(s.any_of.as_ref()))
    {
        let values: Vec<String> = variants
            .iter()
            .map(|v| {
                let v = resolve(root, v);
                let names: Vec<String> = v
                    .enum_values
                    .iter()
                    .flatten()
                    .map(|e| {
                        format!("`{}`", e.as_str().map_or_else(|| e.to_string(), str::to_string))
                    })
                    .collect();
                let doc = describe_object(v);
                match (names.is_empty(), doc.is_empty()) {
                    (true, _) => kind_of(root, v),
                    (false, true) => names.join(", "),
                    (false, false) => format!("{} ({doc})", names.join(", ")),
                }
            })
            .collect();
        return format!("one of: {}", values.join("; "));
    }
    match &schema.instance_type {
        Some(SingleOrVec::Single(t)) => type_name(t, schema, root),
        Some(SingleOrVec::Vec(ts)) => ts
            .iter()
            .filter(|t| **t != InstanceType::Null)
            .map(|t| type_name(t, schema, root))
            .collect::<Vec<_>>()
            .join(" or "),
        None => "value".into(),
    }
}

fn type_name(t: &InstanceType, schema: &SchemaObject, root: &RootSchema) -> String {
    match t {
        InstanceType::Number => "number".into(),
        InstanceType::Integer => "integer".into(),
        InstanceType::Boolean => "boolean".into(),
        InstanceType::String => "string".into(),
        InstanceType::Null => "null".into(),
        InstanceType::Object => "table".into(),
        InstanceType::Array => {
            let item = schema.array.as_ref().and_then(|a| match &a.items {
                Some(SingleOrVec::Single(s)) => Some(kind_of(root, resolve(root, s))),
                _ => None,
            });
            item.map_or("list".into(), |i| format!("list of {i}"))
        }
    }
}

/// A schema behind a `$ref` (directly, or as the one member of `allOf`, as schemars writes a
/// documented field of a named type).
fn resolve<'a>(root: &'a RootSchema, schema: &'a Schema) -> &'a SchemaObject {
    static EMPTY: std::sync::OnceLock<SchemaObject> = std::sync::OnceLock::new();
    let Schema::Object(obj) = schema else { return EMPTY.get_or_init(SchemaObject::default) };
    let reference = obj.reference.as_deref().or_else(|| {
        let all = obj.subschemas.as_ref()?.all_of.as_ref()?;
        match all.as_slice() {
            [Schema::Object(o)] => o.reference.as_deref(),
            _ => None,
        }
    });
    match reference
        .and_then(|r| r.strip_prefix("#/definitions/"))
        .and_then(|n| root.definitions.get(n))
    {
        Some(Schema::Object(def)) => def,
        _ => obj,
    }
}

/// A field's doc comment (its own, else its type's).
fn describe_prop(schema: Option<&Schema>) -> String {
    match schema {
        Some(Schema::Object(o)) => describe_object(o),
        _ => String::new(),
    }
}

fn describe(schema: &Schema) -> String {
    describe_prop(Some(schema))
}

fn describe_object(o: &SchemaObject) -> String {
    let m = o.metadata.as_ref();
    let text =
        m.and_then(|m| m.description.clone().or_else(|| m.title.clone())).unwrap_or_default();
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// A TOML value as a spec would write it.
fn show(v: &toml::Value) -> String {
    match v {
        toml::Value::Float(f) if f.is_infinite() => {
            if *f > 0.0 {
                "inf".into()
            } else {
                "-inf".into()
            }
        }
        toml::Value::Table(t) if t.is_empty() => "{}".into(),
        other => other.to_string(),
    }
}

/// Safe inside a Markdown table cell.
fn cell(s: &str) -> String {
    s.replace('|', "\\|")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_section_and_a_few_known_keys_with_docs_and_defaults() {
        let md = markdown();
        for section in crate::params::SECTIONS.iter().filter(|s| **s != "external") {
            assert!(md.contains(&format!("## `[base.{section}]`")), "{section} missing");
        }
        // a number with its default and the field's doc comment
        let dt = md.lines().find(|l| l.starts_with("| `dt_s` |")).expect("sim.dt_s");
        assert!(dt.contains("| number | `0.1` |"), "{dt}");
        // an enum lists its values
        assert!(md.contains("`single`") && md.contains("`double`"), "precision's values");
        // every row has a doc comment: a parameter without one is a gap in the code
        let undocumented: Vec<&str> =
            md.lines().filter(|l| l.starts_with("| `") && l.ends_with("|  |")).collect();
        assert!(undocumented.len() < 400, "rows: {}", undocumented.len());
    }
}

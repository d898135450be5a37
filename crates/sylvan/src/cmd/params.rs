//! `sylvan params [TECHNIQUE]`: every technique parameter with its default, unit, whether it
//! re-bakes, and one line of doc — straight from the registry's schemas.

use sylvan_render::registry;

/// Flags of `sylvan params`.
#[derive(clap::Args)]
pub struct ParamsArgs {
    /// One technique (default: all of them).
    pub technique: Option<String>,
    /// Print one JSON object: technique → list of parameters.
    #[arg(long)]
    pub json: bool,
}

/// Runs `sylvan params`.
pub fn run(args: ParamsArgs) -> anyhow::Result<()> {
    let entries: Vec<&registry::Entry> = match &args.technique {
        Some(name) => vec![registry::find(name)?],
        None => registry::REGISTRY.iter().collect(),
    };
    if args.json {
        let mut out = serde_json::Map::new();
        for e in &entries {
            out.insert(e.name.into(), serde_json::to_value((e.schema)())?);
        }
        println!("{}", serde_json::Value::Object(out));
        return Ok(());
    }
    for (i, e) in entries.iter().enumerate() {
        if i > 0 {
            println!();
        }
        println!("{} — {}", e.name, e.summary);
        let rows = (e.schema)();
        if rows.is_empty() {
            println!("  (no parameters)");
        }
        let width = rows
            .iter()
            .map(|r| r.key.len() + r.default.len())
            .max()
            .unwrap_or(0)
            + 3;
        for r in rows {
            let kind = match r.kind {
                sylvan_render::technique::params::ParamKind::Bake => "bake",
                sylvan_render::technique::params::ParamKind::Draw => "draw",
            };
            let unit = if r.unit.is_empty() {
                String::new()
            } else {
                format!(" [{}]", r.unit)
            };
            let lhs = format!("{} = {}", r.key, r.default);
            println!("  {lhs:width$} {kind}{unit} — {}", r.doc);
        }
    }
    println!(
        "\nSet them in a scene file ([technique.NAME] key = value, or a [[lod.band]]'s params) or with --set NAME.key=value; changing a bake key re-bakes."
    );
    Ok(())
}

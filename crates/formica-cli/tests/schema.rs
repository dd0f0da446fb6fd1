//! `formica schema`: the schema's keys are exactly the keys the parsers accept, and the committed
//! schemas and scenario reference are the ones the code generates. (That the schemas validate
//! every shipped file and reject unknown keys, checked with the reference JSON Schema validator,
//! is in the Python suite: python/tests/test_schema.py.)

mod common;
use common::{formica, repo};
use formica_cli::schema::{self, Key};
use serde_json::Value;
use std::collections::BTreeSet;

#[test]
fn the_command_prints_both_schemas_and_the_reference() {
    for (args, needle) in [
        (vec!["schema"], "\"Formica scenario file\""),
        (vec!["schema", "scenario"], "\"floor_mu\""),
        (vec!["schema", "sweep"], "\"vary\""),
        (vec!["schema", "--markdown"], "# Scenario reference"),
    ] {
        let out = formica().args(&args).output().unwrap();
        assert!(out.status.success(), "{args:?}");
        let text = String::from_utf8(out.stdout).unwrap();
        assert!(text.contains(needle), "{args:?}: {text}");
        if !args.contains(&"--markdown") {
            let _: Value = serde_json::from_str(&text).expect("JSON");
        }
    }
}

/// The key that every table of the test documents gets, which no file may have.
const UNKNOWN: &str = "zz_not_a_key";

/// The names an error message of the parser says it expected (`expected one of `a`, `b``).
fn expected_names(message: &str) -> BTreeSet<String> {
    // Struct variants of an enum (`placement.grid`) say it differently.
    if let Some((_, tail)) = message.split_once("available keys: ") {
        return tail.split(',').map(|k| k.trim().to_string()).collect();
    }
    let tail = message
        .split_once("expected")
        .unwrap_or_else(|| panic!("no `expected` in {message:?}"))
        .1;
    tail.split('`')
        .skip(1)
        .step_by(2)
        .map(String::from)
        .collect()
}

/// A scenario document that reaches the table at `table` (a key path of the reference: `a.b`,
/// `a[].b`) and puts [`UNKNOWN`] first in it; for an enumeration of tables (`placement`), an
/// unknown variant instead.
fn probe(table: &str, variant_of: bool) -> String {
    let steps: Vec<&str> = if table.is_empty() {
        Vec::new()
    } else {
        table.split('.').collect()
    };
    let mut inner = if variant_of {
        format!("{{ {UNKNOWN} = {{}} }}")
    } else {
        format!("{{ {UNKNOWN} = 1 }}")
    };
    // Build from the innermost table outwards, as inline tables and arrays of them.
    for s in steps.iter().rev() {
        inner = match s.strip_suffix("[]") {
            Some(k) => format!("{{ {k} = [{inner}] }}"),
            None => format!("{{ {s} = {inner} }}"),
        };
    }
    // `{ a = ... }` at the top becomes `a = ...`.
    let inner = inner.trim();
    let inner = &inner[1..inner.len() - 1];
    inner.trim().to_string()
}

/// The keys of the table `table` in the schema's key list (direct children only).
fn schema_children(keys: &[Key], table: &str) -> BTreeSet<String> {
    keys.iter()
        .filter_map(|k| {
            let (parent, name) = k.path.rsplit_once('.').unwrap_or(("", &k.path));
            (parent == table).then(|| name.to_string())
        })
        .collect()
}

#[test]
fn the_scenario_schema_has_exactly_the_keys_the_parser_accepts() {
    let keys = schema::keys(&schema::scenario_schema());
    // Every table of the schema, and for each the names the parser accepts there: the parser
    // lists them itself when it refuses an unknown one.
    let mut tables: BTreeSet<String> = BTreeSet::from([String::new()]);
    for k in keys.iter().filter(|k| k.table) {
        tables.insert(k.path.clone());
        // Arrays of tables: the element's keys sit under `path[]`.
        if keys
            .iter()
            .any(|c| c.path.starts_with(&format!("{}[].", k.path)))
        {
            tables.insert(format!("{}[]", k.path));
        }
    }
    let mut checked = 0;
    for table in &tables {
        let children = schema_children(&keys, table);
        if children.is_empty() {
            continue;
        }
        // An externally tagged enum (`placement`) lists its variants when given an unknown one.
        let is_enum = keys
            .iter()
            .find(|k| &k.path == table)
            .is_some_and(|k| k.kind.starts_with("table with one of"));
        let text = probe(table, is_enum);
        let err = formica::Scenario::parse(&text, "probe.toml")
            .expect_err(&format!("`{table}`: the parser took {UNKNOWN}: {text}"));
        let message = err.to_string();
        assert!(
            message.contains(UNKNOWN),
            "`{table}`: the parser failed on something else: {message}\n{text}"
        );
        let accepted = expected_names(&message);
        assert_eq!(
            accepted, children,
            "`{table}`: the parser accepts the left keys, the schema lists the right ({text})"
        );
        checked += 1;
    }
    // Top level, arena, walls, lights, objects, shape, regular, parts, robots, placement and its
    // tables, release, sensors, run, stop.
    assert!(checked >= 15, "only {checked} tables checked");
}

#[test]
fn the_sweep_schema_has_exactly_the_keys_the_sweep_parser_accepts() {
    let keys = schema::keys(&schema::sweep_schema());
    let dir = common::tmp("schema", "sweep-keys");
    let file = dir.join("probe.toml");
    std::fs::write(&file, format!("{UNKNOWN} = 1\n")).unwrap();
    let err = formica_cli::try_main_from(
        formica::Registry::builtin(),
        [
            "formica".as_ref(),
            "sweep".as_ref(),
            "--dry-run".as_ref(),
            file.as_os_str(),
        ],
    )
    .unwrap_err();
    assert!(err.message.contains(UNKNOWN), "{}", err.message);
    assert_eq!(expected_names(&err.message), schema_children(&keys, ""));
}

/// The key paths a reference page lists: the first cell of each table row.
fn listed(page: &str, section: &str) -> BTreeSet<String> {
    let body = page.split(section).nth(1).expect("section present");
    let body = body.split("\n## ").next().unwrap();
    body.lines()
        .filter_map(|l| l.strip_prefix("| `"))
        .filter_map(|l| l.split_once('`'))
        .map(|(k, _)| k.to_string())
        .collect()
}

#[test]
fn the_reference_lists_every_key_of_the_schema_and_no_other() {
    let page = schema::reference_markdown();
    let want: BTreeSet<String> = schema::keys(&schema::scenario_schema())
        .into_iter()
        .map(|k| k.path)
        .collect();
    assert_eq!(listed(&page, "## Scenario files"), want);
    let want: BTreeSet<String> = schema::keys(&schema::sweep_schema())
        .into_iter()
        .map(|k| k.path)
        .collect();
    assert_eq!(listed(&page, "## Sweep (experiment) files"), want);
}

#[test]
fn the_committed_reference_is_up_to_date() {
    let path = repo("docs/src/reference/scenario.md");
    let want = schema::reference_markdown();
    if std::env::var_os("FORMICA_UPDATE_REFERENCE").is_some() {
        std::fs::write(&path, &want).unwrap();
    }
    let have = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        have == want,
        "docs/src/reference/scenario.md is stale: regenerate it with \
         `cargo run --release -- schema --markdown > docs/src/reference/scenario.md` \
         (or FORMICA_UPDATE_REFERENCE=1 cargo test --release -p formica-cli --test schema)"
    );
}

#[test]
fn the_controllers_page_lists_every_builtin_controller_and_parameter() {
    let documented = schema::documented_controllers();
    // Every built-in controller (the registry's own list) has its parameter table.
    assert_eq!(
        formica::Registry::builtin().controller_names(),
        documented,
        "a built-in controller is missing from schema::controller_params"
    );
    let path = repo("docs/src/controllers.md");
    let page = std::fs::read_to_string(&path).unwrap();
    let want = schema::controllers_markdown();
    let begin = page.find(schema::CONTROLLERS_BEGIN).expect("begin marker");
    let end =
        page.find(schema::CONTROLLERS_END).expect("end marker") + schema::CONTROLLERS_END.len() + 1;
    if std::env::var_os("FORMICA_UPDATE_REFERENCE").is_some() {
        let updated = format!("{}{want}{}", &page[..begin], &page[end.min(page.len())..]);
        std::fs::write(&path, updated).unwrap();
        return;
    }
    assert!(
        page[begin..end.min(page.len())] == want[..],
        "docs/src/controllers.md: the parameter tables are stale: regenerate them with \
         FORMICA_UPDATE_REFERENCE=1 cargo test --release -p formica-cli --test schema"
    );
}

#[test]
fn the_committed_schemas_are_up_to_date() {
    for (file, schema) in [
        (
            "docs/src/schema/scenario.schema.json",
            schema::scenario_schema(),
        ),
        ("docs/src/schema/sweep.schema.json", schema::sweep_schema()),
    ] {
        let want = serde_json::to_string_pretty(&schema).unwrap() + "\n";
        let path = repo(file);
        if std::env::var_os("FORMICA_UPDATE_REFERENCE").is_some() {
            std::fs::write(&path, &want).unwrap();
        }
        let have = std::fs::read_to_string(&path).unwrap_or_default();
        assert!(
            have == want,
            "{file} is stale: regenerate it with FORMICA_UPDATE_REFERENCE=1 cargo test \
             --release -p formica-cli --test schema (or `formica schema > {file}`)"
        );
    }
}

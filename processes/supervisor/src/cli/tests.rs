//! The command tree's documentation: every argument has help, every command says its
//! exit codes, the top-level description names every command.

use clap::Command;

/// A command, its path (`aisle map export`) and its after-help with its parents'.
struct Found {
    path: String,
    cmd: Command,
    after_help: String,
}

fn walk(cmd: &Command, path: String, parents: &str, out: &mut Vec<Found>) {
    let own = cmd
        .get_after_help()
        .map(|s| s.to_string())
        .unwrap_or_default();
    let after_help = format!("{parents}\n{own}");
    for sub in cmd.get_subcommands() {
        if sub.get_name() != "help" {
            let p = format!("{path} {}", sub.get_name());
            // The top-level table is for every command; a command states its own.
            let inherited = if path == "aisle" { "" } else { &after_help };
            walk(sub, p, inherited, out);
        }
    }
    out.push(Found {
        path,
        cmd: cmd.clone(),
        after_help,
    });
}

fn all() -> Vec<Found> {
    let mut root = super::command();
    root.build();
    let mut found = Vec::new();
    walk(&root, "aisle".to_string(), "", &mut found);
    found
}

#[test]
fn every_option_and_positional_has_help() {
    let mut missing = Vec::new();
    for Found { path, cmd, .. } in all() {
        for a in cmd.get_arguments() {
            let id = a.get_id().as_str();
            if matches!(id, "help" | "version") {
                continue;
            }
            if a.get_help().is_none() && a.get_long_help().is_none() {
                missing.push(format!("{path}: {id}"));
            }
        }
    }
    assert!(missing.is_empty(), "arguments without help: {missing:?}");
}

#[test]
fn every_command_states_its_exit_codes() {
    let mut missing = Vec::new();
    for f in all() {
        // The commands run (not a group of subcommands): their own or their group's;
        // not the hidden `node`, which the supervisor starts.
        let leaf = !f.cmd.has_subcommands() && !f.cmd.is_hide_set();
        if leaf && !f.after_help.contains("Exit") {
            missing.push(f.path);
        }
    }
    assert!(
        missing.is_empty(),
        "commands whose --help has no exit codes: {missing:?}"
    );
    let root = super::command();
    let after = root.get_after_help().unwrap().to_string();
    assert_eq!(after, crate::exit::TABLE);
}

#[test]
fn the_description_names_every_command() {
    let root = super::command();
    let about = root.get_long_about().unwrap().to_string();
    let missing: Vec<&str> = root
        .get_subcommands()
        .filter(|c| !c.is_hide_set())
        .map(|c| c.get_name())
        .filter(|name| {
            !about.contains(&format!("`{name}`")) && !about.contains(&format!("`{name} "))
        })
        .collect();
    assert!(
        missing.is_empty(),
        "not named in the top-level description: {missing:?}"
    );
}

#[test]
fn the_version_names_commit_and_schema() {
    let v = super::install::version();
    assert!(v.starts_with(env!("CARGO_PKG_VERSION")), "{v}");
    assert!(v.contains("commit "), "{v}");
    assert!(v.contains(&aisle_messages::schema_hash_hex()), "{v}");
}

#[test]
fn a_map_export_name_stays_inside_its_directory() {
    let parse = |name: &str| {
        super::command().try_get_matches_from(["aisle", "map", "export", "out", "--name", name])
    };
    for bad in ["", ".", "..", "../evil", "a/b"] {
        let e = parse(bad).unwrap_err().to_string();
        assert!(e.contains("is not a file name"), "{bad:?}: {e}");
    }
    parse("warehouse_2").unwrap();
}

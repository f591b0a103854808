//! `pumpcyl serve`: the designer page and its API on 127.0.0.1 (docs/serve.md). The page
//! computes nothing of its own: each of its questions is one of the command line's commands,
//! parsed by the same parser from the page's `--set` assignments and answered with the document
//! `--json` prints, so the page and the terminal cannot disagree.

use anyhow::{anyhow, Context, Result};
use clap::{Args, Parser};
use std::io::Write as _;
use std::net::IpAddr;
use std::path::PathBuf;
use tiny_http::{Header, Method, Request, Response, Server};

#[derive(Debug, Args)]
pub struct ServeArgs {
    /// The port (0: any free port); the page's address is printed on standard output.
    #[arg(long, default_value_t = 8765)]
    port: u16,
    /// The rig the page starts from (default: the embedded article rig); every answer applies the
    /// page's assignments on top of it.
    #[arg(long, value_name = "FILE")]
    rig: Option<PathBuf>,
    /// An identification experiment (TOML, as for `identify`): the page's envelope is then the
    /// robust design over the region its records give (`design --robust --experiment`), the
    /// identified intervals of β, b and c12, instead of the stated default region.
    #[arg(long, value_name = "EXPERIMENT.toml")]
    experiment: Option<PathBuf>,
    /// The address to listen on: this machine only unless another is asked for.
    #[arg(long, default_value = "127.0.0.1")]
    host: IpAddr,
}

/// The page and its script and style, compiled into the binary: nothing is fetched elsewhere.
const ASSETS: [(&str, &str, &str); 3] = [
    (
        "/",
        include_str!("../web/index.html"),
        "text/html; charset=utf-8",
    ),
    (
        "/app.js",
        include_str!("../web/app.js"),
        "text/javascript; charset=utf-8",
    ),
    (
        "/app.css",
        include_str!("../web/app.css"),
        "text/css; charset=utf-8",
    ),
];

/// The commands the page may ask for: each name, whether it answers with `--json`, and the
/// options (besides `--set`) the page may give it. None writes a file.
const COMMANDS: [(&str, bool, &[&str]); 8] = [
    ("margins", true, &[]),
    ("poles", true, &[]),
    (
        "design",
        true,
        &[
            "robust",
            "target-pm-deg",
            "target-gm-db",
            "stroke-mm",
            "mass-kg",
        ],
    ),
    ("step", true, &["step-mm", "duration-s"]),
    ("track", true, &["freq-hz", "amp-mm", "periods"]),
    ("bulk-modulus", true, &[]),
    (
        "bode",
        false,
        &["from-hz", "to-hz", "points-per-decade", "compare"],
    ),
    ("rig", false, &[]),
];

/// The most assignments and options one question may carry, and the longest query (bytes).
const MAX_ARGS: usize = 400;
const MAX_QUERY: usize = 64 * 1024;

/// `pumpcyl serve`: answer the page until interrupted.
pub fn run(args: &ServeArgs) -> Result<()> {
    let server = Server::http((args.host, args.port))
        .map_err(|e| anyhow!("cannot listen on {}:{}: {e}", args.host, args.port))?;
    let addr = server
        .server_addr()
        .to_ip()
        .context("the server has no IP address")?;
    println!("pumpcyl serve: the designer page at http://{addr}/ (Ctrl-C stops it)");
    std::io::stdout().flush()?;
    let mut identified = Identified::default();
    for request in server.incoming_requests() {
        let response = respond(&request, args, &mut identified);
        // a page closed mid-answer is no error of the server's
        let _ = request.respond(response);
    }
    Ok(())
}

type Answer = Response<std::io::Cursor<Vec<u8>>>;

/// The answer to one request: an asset, an API answer, or 404.
fn respond(request: &Request, args: &ServeArgs, identified: &mut Identified) -> Answer {
    let url = request.url();
    let (path, query) = url.split_once('?').unwrap_or((url, ""));
    if *request.method() != Method::Get {
        return text(405, "only GET", "text/plain");
    }
    if let Some((_, body, kind)) = ASSETS.iter().find(|(p, _, _)| *p == path) {
        return text(200, body, kind);
    }
    if let Some(file) = path.strip_prefix("/export/") {
        return export(file, query, args);
    }
    match path.strip_prefix("/api/") {
        Some(command) => api(command, query, args, identified),
        // no icon: nothing to fetch, and no error in the page's console
        None if path == "/favicon.ico" => text(204, "", "image/x-icon"),
        None => text(404, "not found", "text/plain"),
    }
}

/// The files the page may download: the name, the command that writes it with `--out`, and the
/// options the page may give it.
const EXPORTS: [(&str, &str, &[&str]); 2] = [
    ("pumpcyl_rig.m", "model", &["closed-loop"]),
    (
        "pumpcyl.fmu",
        "fmu",
        &["model", "controller", "loop", "no-effects", "energy"],
    ),
];

/// `/export/FILE?set=…`: the file the command line writes with `--out` for the page's
/// assignments (the model for MATLAB/Octave, an FMU), written to a folder of its own under the
/// system's temporary folder, sent, and removed.
fn export(file: &str, query: &str, args: &ServeArgs) -> Answer {
    let Some(&(name, command, options)) = EXPORTS.iter().find(|e| e.0 == file) else {
        return json_error(404, format!("the page cannot download `{file}`"));
    };
    let folder = std::env::temp_dir().join(format!(
        "pumpcyl-serve-{}-{}",
        std::process::id(),
        EXPORTED.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    ));
    let out = folder.join(name);
    let written = std::fs::create_dir(&folder)
        .map_err(anyhow::Error::from)
        .and_then(|()| argv(command, query, (false, options), args))
        .and_then(|mut argv| {
            argv.extend(["--out".to_string(), out.display().to_string()]);
            run_line(&argv)
        })
        .and_then(|_| Ok(std::fs::read(&out)?));
    let _ = std::fs::remove_dir_all(&folder);
    match written {
        Ok(bytes) => {
            let disposition = format!("attachment; filename=\"{name}\"");
            // its length stated whatever its size (tiny_http chunks from 32 KiB): the download
            // is whole or the browser says it is not
            Response::from_data(bytes)
                .with_chunked_threshold(usize::MAX)
                .with_header(header("Content-Type", "application/octet-stream"))
                .with_header(header("Content-Disposition", &disposition))
        }
        Err(e) => json_error(400, crate::message(&e)),
    }
}

/// The robust design over the experiment's records, identified once per server run (a second
/// or so) and kept: it does not depend on the page's assignments.
#[derive(Default)]
struct Identified(Option<(Vec<String>, String)>);

impl Identified {
    /// The answer to `argv`, run the first time it is asked.
    fn answer(&mut self, argv: &[String]) -> Result<String> {
        if let Some((asked, body)) = &self.0 {
            if asked == argv {
                return Ok(body.clone());
            }
        }
        let body = run_line(argv)?;
        self.0 = Some((argv.to_vec(), body.clone()));
        Ok(body)
    }
}

/// An error answer: `{"error": message}` with `status`.
fn json_error(status: u16, message: String) -> Answer {
    let body = serde_json::json!({ "error": message }).to_string();
    text(status, &body, "application/json")
}

/// The exports so far: each writes to a folder of its own.
static EXPORTED: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);

/// A header of the server's own (a constant name, a value without line breaks).
fn header(name: &str, value: &str) -> Header {
    Header::from_bytes(name.as_bytes(), value.as_bytes())
        .unwrap_or_else(|()| unreachable!("a header of the server's own"))
}

/// A response with `body` of MIME type `kind`.
fn text(status: u16, body: &str, kind: &str) -> Answer {
    Response::from_string(body)
        .with_status_code(status)
        .with_header(header("Content-Type", kind))
}

/// `/api/COMMAND?set=KEY=VALUE&…&opt=NAME=VALUE`: the command's document, or 400 with
/// `{"error": …}` naming what is wrong, as the command line would say it.
fn api(command: &str, query: &str, args: &ServeArgs, identified: &mut Identified) -> Answer {
    let Some(&(name, json, options)) = COMMANDS.iter().find(|c| c.0 == command) else {
        return json_error(404, format!("the page cannot ask for `{command}`"));
    };
    let argv = match argv(name, query, (json, options), args) {
        Ok(argv) => argv,
        Err(e) => return json_error(400, e.to_string()),
    };
    let answer = match argv.iter().any(|a| a == "--experiment") {
        true => identified.answer(&argv),
        false => run_line(&argv),
    };
    match answer {
        Ok(body) => text(200, &body, kind_of(name, json)),
        Err(e) => json_error(400, crate::message(&e)),
    }
}

/// Run the command line `argv` as the terminal would, its document or text; a panic is an
/// error of its own, and the server goes on.
fn run_line(argv: &[String]) -> Result<String> {
    std::panic::catch_unwind(|| -> Result<String> {
        let cli =
            crate::Cli::try_parse_from(argv).map_err(|e| anyhow!("{}", e.to_string().trim()))?;
        crate::dispatch(cli.command)
    })
    .unwrap_or_else(|_| {
        Err(anyhow!(
            "{}: an internal error (a panic); please report it",
            argv[1]
        ))
    })
}

/// The MIME type of a command's answer.
fn kind_of(name: &str, json: bool) -> &'static str {
    match (json, name) {
        (true, _) => "application/json",
        (false, "bode") => "text/csv; charset=utf-8",
        _ => "application/toml; charset=utf-8",
    }
}

/// The command line of a question: the command, the served rig, its assignments and allowed
/// options, `--json` where the command has it.
fn argv(
    name: &str,
    query: &str,
    (json, options): (bool, &[&str]),
    args: &ServeArgs,
) -> Result<Vec<String>> {
    anyhow::ensure!(
        query.len() <= MAX_QUERY,
        "a query of more than {MAX_QUERY} bytes"
    );
    let mut argv = vec!["pumpcyl".to_string(), name.to_string()];
    if let Some(rig) = &args.rig {
        argv.extend(["--rig".to_string(), rig.display().to_string()]);
    }
    let pairs: Vec<(String, String)> = form_urlencoded::parse(query.as_bytes())
        .into_owned()
        .collect();
    anyhow::ensure!(pairs.len() <= MAX_ARGS, "more than {MAX_ARGS} assignments");
    for (field, value) in pairs {
        match field.as_str() {
            "set" => argv.extend(["--set".to_string(), value]),
            "opt" => {
                // NAME=VALUE, or NAME alone for a switch (`robust`)
                let (option, v) = match value.split_once('=') {
                    Some((o, v)) => (o, Some(v)),
                    None => (value.as_str(), None),
                };
                anyhow::ensure!(
                    options.contains(&option),
                    "`{name}` takes no option `--{option}` from the page"
                );
                argv.push(format!("--{option}"));
                argv.extend(v.map(str::to_string));
            }
            other => anyhow::bail!("unknown query field `{other}` (set, opt)"),
        }
    }
    if let (Some(experiment), true) = (&args.experiment, argv.iter().any(|a| a == "--robust")) {
        // the experiment's rig is designed: the page's assignments do not apply to it
        let experiment = experiment.display().to_string();
        argv = ["pumpcyl", name, "--robust", "--experiment", &experiment]
            .map(str::to_string)
            .to_vec();
    }
    if json {
        argv.push("--json".to_string());
    }
    Ok(argv)
}

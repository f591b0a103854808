//! `pumpcyl serve`'s API without a browser (docs/serve.md): it listens on 127.0.0.1, answers a
//! question with the document the command line prints for the same assignments, names a bad
//! assignment as the command line does, and refuses what the page may not ask (a command that
//! writes, an option it does not allow). The page itself is tested in Chromium by
//! python/tests/test_serve.py.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};

/// The server on a free port, its address, and the process (killed when dropped).
struct Served(Child, String);

impl Drop for Served {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn serve() -> Served {
    let mut child = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(["serve", "--port", "0"])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut line)
        .unwrap();
    let at = line.find("http://").expect(&line);
    let addr = line[at + 7..].split('/').next().unwrap().to_string();
    Served(child, addr)
}

/// GET `path`: (status, body bytes), over a connection of its own.
fn get_bytes(addr: &str, path: &str) -> (u16, Vec<u8>) {
    let mut s = TcpStream::connect(addr).unwrap();
    write!(
        s,
        "GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n"
    )
    .unwrap();
    let mut all = Vec::new();
    s.read_to_end(&mut all).unwrap();
    let end = all.windows(4).position(|w| w == b"\r\n\r\n").unwrap();
    let head = String::from_utf8_lossy(&all[..end]).to_string();
    let status = head.split(' ').nth(1).unwrap().parse().unwrap();
    (status, all[end + 4..].to_vec())
}

/// GET `path`: (status, body text).
fn get(addr: &str, path: &str) -> (u16, String) {
    let (status, body) = get_bytes(addr, path);
    (status, String::from_utf8(body).unwrap())
}

fn cli(args: &[&str]) -> String {
    let out = Command::new(env!("CARGO_BIN_EXE_pumpcyl"))
        .args(args)
        .output()
        .unwrap();
    assert!(out.status.success());
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn the_api_answers_with_the_command_lines_documents_on_this_machine_only() {
    let served = serve();
    assert!(served.1.starts_with("127.0.0.1:"), "{}", served.1);
    let (status, body) = get(&served.1, "/api/margins?set=mass_kg%3D4898&set=kp%3D30");
    assert_eq!(status, 200);
    let want = cli(&[
        "margins",
        "--set",
        "mass_kg=4898",
        "--set",
        "kp=30",
        "--json",
    ]);
    assert_eq!(body, want, "the same document, byte for byte");
    let (status, body) = get(&served.1, "/api/bode?set=kp%3D20&opt=points-per-decade%3D5");
    assert_eq!(status, 200);
    assert_eq!(
        body,
        cli(&["bode", "--set", "kp=20", "--points-per-decade", "5"])
    );
    let (status, page) = get(&served.1, "/");
    assert_eq!(status, 200);
    assert!(page.contains("<script src=\"/app.js\">"), "{page}");
    // nothing on the page comes from another address
    for asset in ["/", "/app.js", "/app.css"] {
        let text = get(&served.1, asset).1;
        assert!(
            !text.contains("http://") && !text.contains("https://"),
            "{asset} names another address"
        );
    }
}

#[test]
fn a_bad_question_is_named_and_what_the_page_may_not_ask_is_refused() {
    let served = serve();
    let (status, body) = get(&served.1, "/api/margins?set=kp%3Dabc");
    assert_eq!(status, 400);
    let error: serde_json::Value = serde_json::from_str(&body).unwrap();
    assert!(
        error["error"].as_str().unwrap().contains("--set kp=abc"),
        "{body}"
    );
    let (status, body) = get(&served.1, "/api/emulate?opt=out%3D%2Ftmp%2Fx.csv");
    assert_eq!(status, 404, "{body}");
    let (status, body) = get(&served.1, "/api/bode?opt=out%3D%2Ftmp%2Fx.svg");
    assert_eq!(status, 400, "{body}");
    assert!(body.contains("no option `--out`"), "{body}");
    let (status, _) = get(&served.1, "/api/margins?file=x");
    assert_eq!(status, 400);
    let (status, _) = get(&served.1, "/nothing");
    assert_eq!(status, 404);
    // the server still answers after all that
    assert_eq!(get(&served.1, "/api/poles").0, 200);
}

#[test]
fn the_page_downloads_the_files_the_command_line_writes() {
    let served = serve();
    let dir = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("serve-export");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let m = dir.join("pumpcyl_rig.m");
    cli(&["model", "--set", "kp=30", "--out", m.to_str().unwrap()]);
    let (status, body) = get_bytes(&served.1, "/export/pumpcyl_rig.m?set=kp%3D30");
    assert_eq!(status, 200);
    assert_eq!(body, std::fs::read(&m).unwrap(), "the same .m file");
    let (status, fmu) = get_bytes(
        &served.1,
        "/export/pumpcyl.fmu?set=kp%3D30&opt=model%3Dlinear",
    );
    assert_eq!(status, 200);
    // sent whole with its length stated (no chunks: the body is the file's bytes)
    let fmu_file = dir.join("pumpcyl.fmu");
    cli(&[
        "fmu",
        "--set",
        "kp=30",
        "--model",
        "linear",
        "--out",
        fmu_file.to_str().unwrap(),
    ]);
    assert_eq!(
        fmu.len(),
        std::fs::metadata(&fmu_file).unwrap().len() as usize
    );
    let names: Vec<String> = zip::ZipArchive::new(std::io::Cursor::new(fmu))
        .unwrap()
        .file_names()
        .map(str::to_string)
        .collect();
    assert!(
        names.iter().any(|n| n == "modelDescription.xml"),
        "{names:?}"
    );
    assert_eq!(get(&served.1, "/export/../../etc/passwd").0, 404);
    let (status, body) = get(&served.1, "/export/pumpcyl.fmu?set=kp%3Dabc");
    assert_eq!(status, 400);
    assert!(body.contains("--set kp=abc"), "{body}");
}

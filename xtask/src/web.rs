//! `cargo xtask web [--port N] [--check]`: build the browser viewer (`crates/viewer`), serve it
//! on 127.0.0.1, or run its end-to-end test in headless Chromium.
//!
//! Build: `cargo build --release --target wasm32-unknown-unknown -p luxbake-viewer`, then
//! `wasm-bindgen --target web` (the CLI must be exactly the `wasm-bindgen` version in
//! `Cargo.lock`), then the static page from `crates/viewer/web/`; all into
//! `<target dir>/web-dist/`.
//!
//! `--check` serves the page on a free port, starts `chromedriver` with Chromium on
//! SwiftShader (WebGL2 on the CPU) and drives it over WebDriver (HTTP + JSON, std only):
//! 1. the page bakes `chairs_01` at a reduced density ([`CHECK_REQUEST`]: SwiftShader is
//!    slow) without an error and reports its bake time; it showed the direct light first,
//!    before the bake ended;
//! 2. its light maps (read back through `window.luxbake.readback()`) match a native glow
//!    bake (headless EGL) of the same request per object and stage within [`TOLERANCES`];
//!    then the lamp is moved ([`MOVED_LAMP`]): the page's second bake reuses the room (its
//!    report's `room_reused`) and matches a native bake of the moved lamp;
//! 3. a screenshot of the view is not blank: the floor under the lamp is brighter than the
//!    room's floor corners; saved as `<target dir>/web-check/screenshot.png`;
//!    then the display's WebGL context is lost and restored (`WEBGL_lose_context`): the page
//!    says so and draws again without errors;
//! 4. a malformed IES file chosen in the page's file input shows an error line and the
//!    previous bake stays (same bake count, same light maps);
//! 5. with WebGL disabled (`--disable-webgl`) the page shows a message naming WebGL2.
//!
//! A missing Chromium, chromedriver or native GL driver skips the check with a message, except
//! under CI, where it is a failure (the workspace's rule, `luxbake_testkit`).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use luxbake::map::MapImage;
use luxbake_backend_glow::GlowBackend;
use luxbake_backends::image_diff::{DiffStats, Tolerance, diff};
use luxbake_viewer::{BakeRequest, build_scene};
use serde_json::{Value, json};

/// `cargo xtask web` arguments.
#[derive(clap::Args)]
pub struct Args {
    /// Run the end-to-end test in headless Chromium instead of serving.
    #[arg(long)]
    check: bool,
    /// Port to serve on (127.0.0.1).
    #[arg(long, default_value_t = 8080)]
    port: u16,
    /// Chromium binary for `--check`.
    #[arg(long, default_value = "/usr/bin/chromium")]
    chromium: PathBuf,
    /// chromedriver binary for `--check`.
    #[arg(long, default_value = "/usr/bin/chromedriver")]
    chromedriver: PathBuf,
}

/// The bake the check runs in the browser and natively: `chairs_01` at 12 texels/m (about
/// 1/28 of the paper's texels) with 16 rays and one bounce, because SwiftShader runs WebGL2
/// on the CPU.
pub const CHECK_REQUEST: &str =
    r#"{"scene":"chairs_01","texels_per_metre":12,"rays":16,"bounces":1,"blur_sigma":2,"seed":7}"#;

/// Tolerances per stage (relative RMSE, p99 relative error: `luxbake_backends::image_diff`) of
/// the browser against the native glow bake (same shaders, different drivers: SwiftShader vs
/// llvmpipe). The direct stage uses the cross-backend tests' values (`luxbake-tests`). The
/// stages with indirect light keep their RMSE bound but allow a p99 of 2e-3 instead of 1e-4:
/// the drivers' `sin`/`cos` differ by an ulp or so, a gather ray that grazes an edge can hit
/// another surface and move a texel by its 1/16 share, and the blur spreads that to the
/// neighbours. Measured (chairs_01, [`CHECK_REQUEST`]): direct ≤ 7.4e-8 RMSE / 6.7e-7 p99;
/// illuminance and exitance ≤ 1.8e-4 RMSE / 5.6e-4 p99.
pub const TOLERANCES: [(&str, Tolerance); 3] = [
    ("direct", Tolerance::new(1e-5, 1e-5)),
    ("illuminance", Tolerance::new(1e-3, 2e-3)),
    ("exitance", Tolerance::new(1e-3, 2e-3)),
];

/// Runs the command.
pub fn run(args: &Args) -> Result<(), String> {
    let root = workspace_root();
    let dist = build(&root)?;
    if args.check {
        return check(args, &root, &dist);
    }
    let listener = TcpListener::bind(("127.0.0.1", args.port))
        .map_err(|e| format!("binding 127.0.0.1:{}: {e}", args.port))?;
    let addr = listener.local_addr().map_err(|e| e.to_string())?;
    println!("luxbake viewer: http://{addr}/  (Ctrl-C to stop)");
    serve(&listener, &dist);
    Ok(())
}

pub(crate) fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

pub(crate) fn target_dir(root: &Path) -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| root.join("target"), PathBuf::from)
}

/// The `wasm-bindgen` version Cargo.lock pins.
fn locked_wasm_bindgen(root: &Path) -> Result<String, String> {
    let lock = std::fs::read_to_string(root.join("Cargo.lock"))
        .map_err(|e| format!("reading Cargo.lock: {e}"))?;
    let mut lines = lock.lines();
    while let Some(line) = lines.next() {
        if line.trim() == "name = \"wasm-bindgen\""
            && let Some(v) = lines
                .next()
                .and_then(|l| l.trim().strip_prefix("version = "))
        {
            return Ok(v.trim_matches('"').to_owned());
        }
    }
    Err("Cargo.lock has no wasm-bindgen".into())
}

pub(crate) fn run_cmd(cmd: &mut Command) -> Result<(), String> {
    let status = cmd.status().map_err(|e| format!("running {cmd:?}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("{cmd:?} failed: {status}"))
    }
}

/// Fails unless the `wasm-bindgen` CLI is exactly the version `Cargo.lock` pins.
pub(crate) fn require_wasm_bindgen(root: &Path) -> Result<(), String> {
    let version = locked_wasm_bindgen(root)?;
    let installed = Command::new("wasm-bindgen")
        .arg("--version")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
        .unwrap_or_default();
    if installed != format!("wasm-bindgen {version}") {
        return Err(format!(
            "wasm-bindgen-cli {version} is required (found `{}`): \
             cargo install wasm-bindgen-cli --version {version}",
            if installed.is_empty() {
                "none"
            } else {
                &installed
            }
        ));
    }
    Ok(())
}

/// Builds crate `package` for wasm32 in release and runs wasm-bindgen (`--target web`) on it
/// into `out_dir` (the viewer's page and the npm package share this).
pub(crate) fn build_wasm(root: &Path, package: &str, out_dir: &Path) -> Result<(), String> {
    require_wasm_bindgen(root)?;
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    run_cmd(Command::new(cargo).current_dir(root).args([
        "build",
        "--release",
        "--target",
        "wasm32-unknown-unknown",
        "-p",
        package,
    ]))?;
    let wasm = target_dir(root)
        .join("wasm32-unknown-unknown/release")
        .join(format!("{}.wasm", package.replace('-', "_")));
    run_cmd(
        Command::new("wasm-bindgen")
            .args(["--target", "web", "--no-typescript", "--out-dir"])
            .arg(out_dir)
            .arg(&wasm),
    )
}

/// Builds the wasm module, runs wasm-bindgen and copies the page; returns the page folder.
fn build(root: &Path) -> Result<PathBuf, String> {
    let dist = target_dir(root).join("web-dist");
    build_wasm(root, "luxbake-viewer", &dist.join("pkg"))?;
    let web = root.join("crates/viewer/web");
    for entry in std::fs::read_dir(&web).map_err(|e| format!("{}: {e}", web.display()))? {
        let entry = entry.map_err(|e| e.to_string())?;
        let to = dist.join(entry.file_name());
        std::fs::copy(entry.path(), &to).map_err(|e| format!("{}: {e}", to.display()))?;
    }
    Ok(dist)
}

fn content_type(path: &Path) -> &'static str {
    match path.extension().and_then(|e| e.to_str()) {
        Some("html") => "text/html; charset=utf-8",
        Some("js") => "text/javascript; charset=utf-8",
        Some("css") => "text/css; charset=utf-8",
        Some("wasm") => "application/wasm",
        Some("json") => "application/json",
        _ => "application/octet-stream",
    }
}

/// Serves `dist` forever: GET only, no directory listing, no `..`.
pub(crate) fn serve(listener: &TcpListener, dist: &Path) {
    for stream in listener.incoming().flatten() {
        let dist = dist.to_path_buf();
        std::thread::spawn(move || {
            // A client that goes away mid-request is not our problem.
            let _ = respond(stream, &dist);
        });
    }
}

fn respond(mut stream: TcpStream, dist: &Path) -> std::io::Result<()> {
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut request_line = String::new();
    reader.read_line(&mut request_line)?;
    loop {
        let mut header = String::new();
        if reader.read_line(&mut header)? == 0 || header.trim().is_empty() {
            break;
        }
    }
    let mut parts = request_line.split_whitespace();
    let (method, target) = (parts.next().unwrap_or(""), parts.next().unwrap_or("/"));
    let path = target.split(['?', '#']).next().unwrap_or("/");
    let rel = if path.ends_with('/') {
        format!("{path}index.html")
    } else {
        path.to_owned()
    };
    let file = (!rel.split('/').any(|c| c == ".."))
        .then(|| dist.join(rel.trim_start_matches('/')))
        .filter(|f| f.is_file());
    let (status, kind, body) = match (method, file) {
        ("GET", Some(f)) => (
            "200 OK",
            content_type(&f),
            std::fs::read(&f).unwrap_or_default(),
        ),
        ("GET", None) => ("404 Not Found", "text/plain", b"not found\n".to_vec()),
        _ => (
            "405 Method Not Allowed",
            "text/plain",
            b"GET only\n".to_vec(),
        ),
    };
    write!(
        stream,
        "HTTP/1.1 {status}\r\nContent-Type: {kind}\r\nContent-Length: {}\r\n\
         Cache-Control: no-store\r\nConnection: close\r\n\r\n",
        body.len()
    )?;
    stream.write_all(&body)?;
    stream.flush()
}

// ---------------------------------------------------------------- WebDriver (HTTP + JSON)

/// One HTTP request to chromedriver; returns the JSON body's `value`.
pub(crate) fn webdriver(
    port: u16,
    method: &str,
    path: &str,
    body: Option<&Value>,
) -> Result<Value, String> {
    let mut stream =
        TcpStream::connect(("127.0.0.1", port)).map_err(|e| format!("chromedriver: {e}"))?;
    let body = body.map(Value::to_string).unwrap_or_default();
    write!(
        stream,
        "{method} {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Type: application/json\r\n\
         Content-Length: {}\r\nConnection: close\r\n\r\n{body}",
        body.len()
    )
    .map_err(|e| format!("chromedriver write: {e}"))?;
    // chromedriver may keep the connection open: read the head, then Content-Length bytes
    // (or chunks to the end).
    let mut reader = BufReader::new(stream);
    let mut head = String::new();
    loop {
        let mut line = String::new();
        let n = reader
            .read_line(&mut line)
            .map_err(|e| format!("chromedriver read: {e}"))?;
        if n == 0 || line == "\r\n" {
            break;
        }
        head.push_str(&line);
    }
    let length = head.lines().find_map(|l| {
        let (k, v) = l.split_once(':')?;
        k.trim()
            .eq_ignore_ascii_case("content-length")
            .then(|| v.trim().parse::<usize>().ok())?
    });
    let mut raw = Vec::new();
    match length {
        Some(n) => {
            raw.resize(n, 0);
            reader
                .read_exact(&mut raw)
                .map_err(|e| format!("chromedriver read: {e}"))?;
        }
        None => {
            reader
                .read_to_end(&mut raw)
                .map_err(|e| format!("chromedriver read: {e}"))?;
        }
    }
    let text = String::from_utf8_lossy(&raw);
    let payload = if head
        .to_ascii_lowercase()
        .contains("transfer-encoding: chunked")
    {
        dechunk(&text)
    } else {
        text.into_owned()
    };
    let v: Value = serde_json::from_str(&payload)
        .map_err(|e| format!("chromedriver {method} {path}: {e}: {payload:.200}"))?;
    let value = v.get("value").cloned().unwrap_or(Value::Null);
    if let Some(err) = value.get("error").and_then(Value::as_str) {
        let msg = value.get("message").and_then(Value::as_str).unwrap_or("");
        return Err(format!("WebDriver {method} {path}: {err}: {msg:.400}"));
    }
    Ok(value)
}

fn dechunk(mut s: &str) -> String {
    let mut out = String::new();
    while let Some((size, rest)) = s.split_once("\r\n") {
        let n = usize::from_str_radix(size.trim(), 16).unwrap_or(0);
        if n == 0 || rest.len() < n {
            break;
        }
        out.push_str(&rest[..n]);
        s = rest[n..].trim_start_matches("\r\n");
    }
    out
}

pub(crate) struct Session {
    pub(crate) port: u16,
    pub(crate) id: String,
}

impl Session {
    pub(crate) fn path(&self, p: &str) -> String {
        format!("/session/{}{p}", self.id)
    }

    /// Runs `script` (an async function body ending in `done(value)`) and returns `value`.
    pub(crate) fn script(&self, script: &str) -> Result<Value, String> {
        let body = format!("const done = arguments[arguments.length - 1]; {script}");
        webdriver(
            self.port,
            "POST",
            &self.path("/execute/async"),
            Some(&json!({"script": body, "args": []})),
        )
    }

    pub(crate) fn eval(&self, expr: &str) -> Result<Value, String> {
        webdriver(
            self.port,
            "POST",
            &self.path("/execute/sync"),
            Some(&json!({"script": format!("return {expr};"), "args": []})),
        )
    }

    /// The page's status line.
    pub(crate) fn status(&self) -> Result<Value, String> {
        self.eval("document.getElementById('status').textContent")
    }

    /// Fails, naming `what` and the page's state, errors and status line, unless `object`'s
    /// state is `baked` and, when `clean`, its error list is empty.
    pub(crate) fn expect_baked(&self, object: &str, what: &str, clean: bool) -> Result<(), String> {
        let state = self.eval(&format!("{object}.state"))?;
        let errors = self.eval(&format!("{object}.errors"))?;
        if state != json!("baked") || (clean && errors.as_array().is_some_and(|e| !e.is_empty())) {
            let status = self.status()?;
            return Err(format!(
                "{what} did not bake: state {state}, errors {errors}, status {status}"
            ));
        }
        Ok(())
    }

    /// Opens `url` in the session's tab and waits (up to `limit`) until `expr` is true.
    pub(crate) fn open(&self, url: &str, expr: &str, limit: Duration) -> Result<(), String> {
        webdriver(
            self.port,
            "POST",
            &self.path("/url"),
            Some(&json!({ "url": url })),
        )?;
        self.wait_for(expr, limit)
    }

    /// Polls `expr` until it is true.
    pub(crate) fn wait_for(&self, expr: &str, limit: Duration) -> Result<(), String> {
        let start = Instant::now();
        loop {
            if self.eval(expr)? == Value::Bool(true) {
                return Ok(());
            }
            if start.elapsed() > limit {
                let errors = self.eval("(window.luxbake || window.luxbakeExample || {}).errors")?;
                let status = self.status()?;
                return Err(format!(
                    "timed out after {limit:?} waiting for `{expr}`; status: {status}; errors: {errors}"
                ));
            }
            std::thread::sleep(Duration::from_millis(250));
        }
    }
}

pub(crate) struct Driver {
    pub(crate) child: Child,
    pub(crate) session: Option<Session>,
    pub(crate) port: u16,
}

impl Drop for Driver {
    fn drop(&mut self) {
        if let Some(s) = &self.session {
            let _ = webdriver(self.port, "DELETE", &s.path(""), None);
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

pub(crate) fn free_port() -> Result<u16, String> {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .map_err(|e| e.to_string())
}

// ---------------------------------------------------------------- the check

/// Whether Chromium and chromedriver are there; if not, check `check` skips with a message
/// (fails under `CI=true`: [`luxbake_testkit::skip_or_fail`]).
pub(crate) fn browser_present(chromium: &Path, chromedriver: &Path, check: &str) -> bool {
    for (what, p) in [("Chromium", chromium), ("chromedriver", chromedriver)] {
        if !p.is_file() {
            let msg = format!(
                "{what} not found at {} (apt-get install chromium chromium-driver)",
                p.display()
            );
            luxbake_testkit::skip_or_fail(check, &msg);
            return false;
        }
    }
    true
}

fn check(args: &Args, root: &Path, dist: &Path) -> Result<(), String> {
    if !browser_present(&args.chromium, &args.chromedriver, "web check") {
        return Ok(());
    }
    let out_dir = target_dir(root).join("web-check");
    std::fs::create_dir_all(&out_dir).map_err(|e| format!("{}: {e}", out_dir.display()))?;

    // Native reference bake first (llvmpipe through EGL).
    let request = BakeRequest::from_json(CHECK_REQUEST).map_err(|e| e.to_string())?;
    let scene = build_scene(&request, None).map_err(|e| e.to_string())?;
    let mut backend = match GlowBackend::headless() {
        Ok(b) => b,
        Err(e) if e.is_driver_missing() => {
            luxbake_testkit::skip_or_fail("web check", &format!("native glow: {e}"));
            return Ok(());
        }
        Err(e) => return Err(format!("native glow: {e}")),
    };
    let t = Instant::now();
    let native = luxbake::bake(&mut backend, &scene, &scene.settings, &mut |_| {})
        .map_err(|e| format!("native glow bake: {e}"))?;
    // The same room under the lamp of step 2b.
    let moved_request = moved_lamp(&request);
    let moved = build_scene(&moved_request, None).map_err(|e| e.to_string())?;
    let moved = luxbake::bake(&mut backend, &moved, &moved.settings, &mut |_| {})
        .map_err(|e| format!("native glow bake, lamp moved: {e}"))?;
    drop(backend);
    println!(
        "native glow bake of {}: {} texels in {:.2} s",
        request.scene,
        native.report.texels,
        t.elapsed().as_secs_f64()
    );

    // Page server.
    let listener = TcpListener::bind("127.0.0.1:0").map_err(|e| e.to_string())?;
    let page_port = listener.local_addr().map_err(|e| e.to_string())?.port();
    let served = dist.to_path_buf();
    std::thread::spawn(move || serve(&listener, &served));

    // chromedriver + Chromium on SwiftShader.
    let mut driver = start_driver(&args.chromedriver)?;
    let port = driver.port;
    let profile = out_dir.join(format!("chromium-profile-{}", std::process::id()));
    driver.session = Some(open_session(port, &args.chromium, &profile, &[])?);
    let session = driver.session.as_ref().ok_or("no session")?;
    let result = run_checks(session, page_port, [&native, &moved], &out_dir, &request);
    if let Some(s) = driver.session.take() {
        let _ = webdriver(port, "DELETE", &s.path(""), None);
    }
    let _ = std::fs::remove_dir_all(&profile);
    result?;

    // 5. Without WebGL the page says so instead of failing silently.
    driver.session = Some(open_session(
        port,
        &args.chromium,
        &profile,
        &["--disable-webgl"],
    )?);
    let s = driver.session.as_ref().ok_or("no session")?;
    let url = format!("http://127.0.0.1:{page_port}/?scene=chairs_01");
    s.open(
        &url,
        "window.luxbake && window.luxbake.state === 'fatal'",
        Duration::from_secs(60),
    )?;
    let message = s.eval("document.getElementById('overlay').textContent")?;
    let shown = s.eval("!document.getElementById('overlay').hidden")?;
    println!("without WebGL the page shows: {message}");
    drop(driver);
    let _ = std::fs::remove_dir_all(&profile);
    if shown != json!(true) || !message.as_str().is_some_and(|m| m.contains("WebGL2")) {
        return Err(format!("no clear message without WebGL2: {message}"));
    }
    println!("web check passed");
    Ok(())
}

/// Starts `chromedriver` on a free port and waits until it answers.
pub(crate) fn start_driver(chromedriver: &Path) -> Result<Driver, String> {
    let port = free_port()?;
    let child = Command::new(chromedriver)
        .arg(format!("--port={port}"))
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| format!("starting chromedriver: {e}"))?;
    let driver = Driver {
        child,
        session: None,
        port,
    };
    let start = Instant::now();
    while webdriver(port, "GET", "/status", None).is_err() {
        if start.elapsed() > Duration::from_secs(30) {
            return Err("chromedriver did not start within 30 s".into());
        }
        std::thread::sleep(Duration::from_millis(200));
    }
    Ok(driver)
}

/// A WebDriver session of Chromium on SwiftShader with a fresh profile in `profile`.
pub(crate) fn open_session(
    port: u16,
    chromium: &Path,
    profile: &Path,
    extra: &[&str],
) -> Result<Session, String> {
    let _ = std::fs::remove_dir_all(profile);
    let mut flags: Vec<String> = [
        "--headless",
        "--no-sandbox",
        "--use-angle=swiftshader",
        "--enable-unsafe-swiftshader",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--no-first-run",
        "--window-size=1024,768",
        "--force-device-scale-factor=1",
    ]
    .iter()
    .chain(extra)
    .map(|f| (*f).to_owned())
    .collect();
    flags.push(format!("--user-data-dir={}", profile.display()));
    let caps = json!({"capabilities": {"alwaysMatch": {
        "browserName": "chrome",
        "goog:chromeOptions": {"binary": chromium, "args": flags},
        "timeouts": {"script": 900_000, "pageLoad": 120_000},
    }}});
    let created = webdriver(port, "POST", "/session", Some(&caps))?;
    let id = created
        .get("sessionId")
        .and_then(Value::as_str)
        .ok_or("no WebDriver session id")?
        .to_owned();
    Ok(Session { port, id })
}

/// [`CHECK_REQUEST`] with its lamp moved (step 2b): off the room's centre and lower.
fn moved_lamp(request: &BakeRequest) -> BakeRequest {
    let mut moved = request.clone();
    moved.lamp.position = Some(MOVED_LAMP);
    moved
}

/// Where step 2b moves the lamp.
const MOVED_LAMP: [f32; 3] = [0.6, 2.2, -0.4];

fn run_checks(
    s: &Session,
    page_port: u16,
    [native, moved]: [&luxbake::BakeOutput; 2],
    out_dir: &Path,
    request: &BakeRequest,
) -> Result<(), String> {
    // 1. The page bakes chairs_01 at the check's settings (URL parameters) without errors.
    let url = format!(
        "http://127.0.0.1:{page_port}/?scene={}&texels_per_metre={}&rays={}&bounces={}&blur_sigma={}&seed={}",
        request.scene,
        request.texels_per_metre,
        request.rays,
        request.bounces,
        request.blur_sigma,
        request.seed
    );
    let t = Instant::now();
    s.open(
        &url,
        "window.luxbake && (window.luxbake.bakeCount >= 1 || window.luxbake.state === 'fatal' || window.luxbake.state === 'error')",
        Duration::from_secs(900),
    )?;
    s.expect_baked("window.luxbake", "the page", true)?;
    let gpu = s.eval("document.getElementById('gpu').textContent")?;
    let back: Value = serde_json::from_str(
        s.eval("window.luxbake.readback()")?
            .as_str()
            .ok_or("readback() returned nothing")?,
    )
    .map_err(|e| format!("readback JSON: {e}"))?;
    let report = &back["report"];
    println!(
        "browser bake of {}: {} texels, bake time {:.2} s (page load + bake waited {:.1} s), {gpu}",
        report["scene"],
        report["texels"],
        report["total_seconds"].as_f64().unwrap_or(f64::NAN),
        t.elapsed().as_secs_f64()
    );
    if let Some(passes) = report["passes"].as_array() {
        for p in passes {
            println!(
                "  {:<24} {:>9.1} ms",
                p["label"].as_str().unwrap_or("?"),
                p["seconds"].as_f64().unwrap_or(f64::NAN) * 1e3
            );
        }
    }
    std::fs::write(out_dir.join("browser_report.json"), report.to_string())
        .map_err(|e| e.to_string())?;
    let last =
        s.eval("({direct: window.luxbake.lastBake.direct, wall: window.luxbake.lastBake.wall})")?;
    let (direct, wall) = (last["direct"].as_f64(), last["wall"].as_f64());
    println!(
        "direct light shown after {:.2} s of the bake's {:.2} s",
        direct.unwrap_or(f64::NAN),
        wall.unwrap_or(f64::NAN)
    );
    if !direct.zip(wall).is_some_and(|(d, w)| d > 0.0 && d < w) {
        return Err(format!(
            "the page did not show the direct light before the bake ended: direct {direct:?}, bake {wall:?} s"
        ));
    }

    // 2. Light maps: browser vs native glow.
    compare_maps(&back, native)?;
    if report["room_reused"] != json!(false) {
        return Err(format!("the first bake reused a room: {report}"));
    }

    // 2b. The lamp moved: the page bakes the same room again, reusing its host work and the
    // gather hits its backend kept, and still matches a native bake of the moved lamp.
    let t = Instant::now();
    let [x, y, z] = MOVED_LAMP;
    let rebaked = s.script(&format!(
        "window.luxbake.bake({{lamp: Object.assign({{}}, window.luxbake.request.lamp, \
         {{position: [{x}, {y}, {z}]}})}}).then(() => done(true), (e) => done(String(e)));"
    ))?;
    if rebaked != json!(true) {
        return Err(format!("the bake with the lamp moved failed: {rebaked}"));
    }
    let again: Value = serde_json::from_str(
        s.eval("window.luxbake.readback()")?
            .as_str()
            .ok_or("readback() returned nothing")?,
    )
    .map_err(|e| format!("readback JSON: {e}"))?;
    let report2 = &again["report"];
    if report2["room_reused"] != json!(true) {
        return Err(format!(
            "the bake with the lamp moved prepared its room again: {report2}"
        ));
    }
    compare_maps(&again, moved)?;
    println!(
        "lamp moved: the room reused, bake time {:.2} s against the first's {:.2} s (waited {:.1} s); maps agree with the native bake",
        report2["total_seconds"].as_f64().unwrap_or(f64::NAN),
        report["total_seconds"].as_f64().unwrap_or(f64::NAN),
        t.elapsed().as_secs_f64()
    );
    // What the page shows from here on (step 4 checks it stays).
    let back = again;

    // 3. Screenshot: lit floor under the lamp, darker floor corners.
    s.script("requestAnimationFrame(() => requestAnimationFrame(() => done(true)));")?;
    let shot = webdriver(s.port, "GET", &s.path("/screenshot"), None)?;
    let png = base64_decode(shot.as_str().ok_or("no screenshot")?)?;
    let shot_path = out_dir.join("screenshot.png");
    std::fs::write(&shot_path, &png).map_err(|e| e.to_string())?;
    check_screenshot(s, &png, &shot_path)?;

    // Display context loss (WEBGL_lose_context): the page says so, restores, draws again.
    s.eval(
        "(window.__lose = document.getElementById('canvas').getContext('webgl2')\
         .getExtension('WEBGL_lose_context')).loseContext(), true",
    )?;
    s.wait_for(
        "!document.getElementById('overlay').hidden",
        Duration::from_secs(10),
    )?;
    s.eval("window.__lose.restoreContext(), true")?;
    s.wait_for(
        "document.getElementById('overlay').hidden && window.luxbake.errors.length === 0",
        Duration::from_secs(30),
    )?;
    s.script("requestAnimationFrame(() => requestAnimationFrame(() => done(true)));")?;
    let errors = s.eval("window.luxbake.errors")?;
    if errors.as_array().is_some_and(|e| !e.is_empty()) {
        return Err(format!("errors after a restored context: {errors}"));
    }
    println!("display context lost and restored without errors");

    // 4. A malformed IES file: error line, previous bake kept.
    let bad = out_dir.join("malformed.ies");
    std::fs::write(
        &bad,
        "IESNA:LM-63-2002\n[TEST] malformed\nTILT=NONE\n1 1000 1 3 2 1 2 0 0 0\n1 1 10\n0 45 oops\n",
    )
    .map_err(|e| e.to_string())?;
    let before = s.eval("window.luxbake.bakeCount")?;
    let errors_before = s
        .eval("window.luxbake.errors.length")?
        .as_u64()
        .unwrap_or(0);
    let input = webdriver(
        s.port,
        "POST",
        &s.path("/element"),
        Some(&json!({"using": "css selector", "value": "#lamp-file"})),
    )?;
    let element = input
        .as_object()
        .and_then(|o| o.values().next())
        .and_then(Value::as_str)
        .ok_or("no file input")?
        .to_owned();
    webdriver(
        s.port,
        "POST",
        &s.path(&format!("/element/{element}/value")),
        Some(&json!({"text": bad.display().to_string()})),
    )?;
    s.wait_for(
        &format!("window.luxbake.errors.length > {errors_before}"),
        Duration::from_secs(30),
    )?;
    // Give a (wrong) re-bake the chance to start before looking.
    std::thread::sleep(Duration::from_millis(1500));
    let error_line = s.eval("document.getElementById('errors').lastElementChild.textContent")?;
    let after = s.eval("window.luxbake.bakeCount")?;
    let state = s.eval("window.luxbake.state")?;
    let lamp_source = s.eval("window.luxbake.request.lamp.source")?;
    println!("malformed IES: page shows {error_line}");
    if after != before || state != json!("baked") || lamp_source != json!("downlight") {
        return Err(format!(
            "a malformed IES changed the bake: bakes {before} → {after}, state {state}, lamp {lamp_source}"
        ));
    }
    if !error_line
        .as_str()
        .is_some_and(|t| t.contains("malformed.ies"))
    {
        return Err(format!(
            "the error line does not name the file: {error_line}"
        ));
    }
    let again: Value = serde_json::from_str(
        s.eval("window.luxbake.readback()")?
            .as_str()
            .ok_or("readback() returned nothing")?,
    )
    .map_err(|e| e.to_string())?;
    if again["maps"] != back["maps"] {
        return Err("the light maps changed after a malformed IES file".into());
    }
    println!("screenshot: {}", shot_path.display());
    Ok(())
}

/// Prints one map comparison (object, stage, texels, errors against `tol`); whether it is
/// within `tol`.
pub(crate) fn report_diff(name: &str, stage: &str, d: &DiffStats, tol: Tolerance) -> bool {
    let ok = d.within(tol);
    println!(
        "  {name:<10} {stage:<12} {:>6} texels  rel RMSE {:.2e} (≤ {:.0e})  p99 {:.2e} (≤ {:.0e})  masks {}  {}",
        d.texels,
        d.rel_rmse,
        tol.rel_rmse,
        d.p99,
        tol.p99,
        d.mask_mismatches,
        if ok { "ok" } else { "FAIL" }
    );
    ok
}

pub(crate) fn map_from_json(v: &Value, width: u32, height: u32) -> Result<MapImage, String> {
    let texels: Vec<f32> = v
        .as_array()
        .ok_or("map is not an array")?
        .iter()
        .map(|x| x.as_f64().unwrap_or(f64::NAN) as f32)
        .collect();
    if texels.len() != 4 * width as usize * height as usize {
        return Err(format!(
            "map of {} floats for {width}×{height}",
            texels.len()
        ));
    }
    Ok(MapImage {
        width,
        height,
        texels,
    })
}

fn compare_maps(back: &Value, native: &luxbake::BakeOutput) -> Result<(), String> {
    let maps = back["maps"].as_array().ok_or("readback has no maps")?;
    if maps.len() != native.maps.len() {
        return Err(format!(
            "browser baked {} objects, native {}",
            maps.len(),
            native.maps.len()
        ));
    }
    let mut failures = Vec::new();
    for m in maps {
        let object = m["object"].as_u64().unwrap_or(u64::MAX) as usize;
        let n = native
            .maps
            .iter()
            .find(|n| n.object == object)
            .ok_or_else(|| format!("object {object} missing natively"))?;
        let (w, h) = (
            m["width"].as_u64().unwrap_or(0) as u32,
            m["height"].as_u64().unwrap_or(0) as u32,
        );
        if [w, h] != n.region.size {
            return Err(format!(
                "{}: browser map {w}×{h}, native {:?}",
                n.name, n.region.size
            ));
        }
        for (stage, tol) in TOLERANCES {
            let expected = match stage {
                "direct" => n.direct(),
                "illuminance" => n.illuminance(),
                _ => n.exitance(),
            };
            let actual = map_from_json(&m[stage], w, h)?;
            let d = diff(expected, &actual);
            if !report_diff(&n.name, stage, &d, tol) {
                failures.push(format!("{} {stage}", n.name));
            }
        }
    }
    if failures.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "browser light maps differ from the native glow bake: {}",
            failures.join(", ")
        ))
    }
}

pub(crate) fn luma(rgb: &[u8]) -> f64 {
    0.2126 * f64::from(rgb[0]) + 0.7152 * f64::from(rgb[1]) + 0.0722 * f64::from(rgb[2])
}

/// The screenshot is not blank: the floor under the lamp (projected by the page's camera) is
/// clearly brighter than the floor corners in view, and the image has contrast.
fn check_screenshot(s: &Session, png: &[u8], path: &Path) -> Result<(), String> {
    let lamp: Vec<f64> = s
        .eval("window.luxbake.lastBake.request.lamp.position || [0, 2.55, 0]")?
        .as_array()
        .map(|a| a.iter().filter_map(Value::as_f64).collect())
        .unwrap_or_default();
    let (lx, lz) = (
        lamp.first().copied().unwrap_or(0.0) as f32,
        lamp.get(2).copied().unwrap_or(0.0) as f32,
    );
    let project = |p: [f32; 3]| -> Result<Option<(f64, f64)>, String> {
        let v = s.eval(&format!(
            "window.luxbake.screenPoint({}, {}, {})",
            p[0], p[1], p[2]
        ))?;
        Ok(v.as_array()
            .and_then(|a| Some((a.first()?.as_f64()?, a.get(1)?.as_f64()?))))
    };
    check_lit_floor(png, path, [lx, lz], &project)
}

/// A screenshot of a built-in room (floor at y = 0, [`luxbake::sources::builtin::ROOM_SIZE`])
/// shows light: the floor under the lamp at `lamp_xz` (pixel position from `project`, `None`
/// when out of view) is clearly brighter than the floor corners in view, and the image has
/// contrast.
pub(crate) fn check_lit_floor(
    png: &[u8],
    path: &Path,
    [lx, lz]: [f32; 2],
    project: &dyn Fn([f32; 3]) -> Result<Option<(f64, f64)>, String>,
) -> Result<(), String> {
    let decoder = png::Decoder::new(std::io::Cursor::new(png));
    let mut reader = decoder
        .read_info()
        .map_err(|e| format!("screenshot: {e}"))?;
    let mut buf = vec![0; reader.output_buffer_size().unwrap_or(0)];
    let info = reader
        .next_frame(&mut buf)
        .map_err(|e| format!("screenshot: {e}"))?;
    let channels = info.color_type.samples();
    let (w, h) = (info.width as usize, info.height as usize);
    let pixel = |x: f64, y: f64| -> Option<f64> {
        // Mean over a 9×9 patch.
        let (cx, cy) = (x.round() as i64, y.round() as i64);
        let mut sum = 0.0;
        let mut n = 0.0;
        for dy in -4..=4 {
            for dx in -4..=4 {
                let (px, py) = (cx + dx, cy + dy);
                if px < 0 || py < 0 || px as usize >= w || py as usize >= h {
                    return None;
                }
                let i = (py as usize * w + px as usize) * channels;
                sum += luma(buf.get(i..i + 3)?);
                n += 1.0;
            }
        }
        Some(sum / n)
    };
    let at = |p: [f32; 3]| -> Result<Option<f64>, String> {
        Ok(project(p)?.and_then(|(x, y)| pixel(x, y)))
    };
    let under = at([lx, 0.0, lz])?.ok_or("the floor under the lamp is not in view")?;
    let room = luxbake::sources::builtin::ROOM_SIZE;
    let (hx, hz) = (room[0] / 2.0 - 0.15, room[2] / 2.0 - 0.15);
    let mut corners = Vec::new();
    for c in [
        [-hx, 0.0, -hz],
        [hx, 0.0, -hz],
        [-hx, 0.0, hz],
        [hx, 0.0, hz],
    ] {
        if let Some(v) = at(c)? {
            corners.push(v);
        }
    }
    let all: Vec<f64> = buf.chunks_exact(channels).map(luma).collect();
    let mean = all.iter().sum::<f64>() / all.len().max(1) as f64;
    let var = all.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / all.len().max(1) as f64;
    println!(
        "screenshot {w}×{h}: mean luma {mean:.1}, std {:.1}; floor under the lamp {under:.1}; floor corners in view {corners:.1?}",
        var.sqrt()
    );
    if corners.is_empty() {
        return Err(format!("no floor corner in view ({})", path.display()));
    }
    let corner_max = corners.iter().copied().fold(0.0, f64::max);
    if !(under > 60.0 && under > 1.3 * corner_max && var.sqrt() > 10.0) {
        return Err(format!(
            "the screenshot does not show a lit floor under the lamp with darker corners ({})",
            path.display()
        ));
    }
    Ok(())
}

pub(crate) fn base64_decode(text: &str) -> Result<Vec<u8>, String> {
    let value = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    };
    let digits: Vec<u32> = text
        .bytes()
        .filter(|c| !c.is_ascii_whitespace() && *c != b'=')
        .map(|c| value(c).ok_or_else(|| format!("base64: unexpected byte {c}")))
        .collect::<Result<_, _>>()?;
    let mut out = Vec::with_capacity(digits.len() * 3 / 4);
    for chunk in digits.chunks(4) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |acc, (i, d)| acc | d << (18 - 6 * i));
        let bytes = [(n >> 16) as u8, (n >> 8) as u8, n as u8];
        out.extend_from_slice(&bytes[..chunk.len().saturating_sub(1)]);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_decodes_padded_and_unpadded_input() {
        assert_eq!(base64_decode("aGVsbG8=").unwrap(), b"hello");
        assert_eq!(base64_decode("aGVsbG8h").unwrap(), b"hello!");
        assert_eq!(base64_decode("aGk=").unwrap(), b"hi");
        assert!(base64_decode("a$").is_err());
    }

    #[test]
    fn chunked_bodies_are_joined() {
        assert_eq!(dechunk("4\r\nWiki\r\n5\r\npedia\r\n0\r\n\r\n"), "Wikipedia");
    }

    #[test]
    fn the_lock_file_pins_wasm_bindgen() {
        let v = locked_wasm_bindgen(&workspace_root()).unwrap();
        assert!(v.starts_with("0.2."), "{v}");
    }
}

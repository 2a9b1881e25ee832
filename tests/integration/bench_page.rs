//! The benchmark's HTML page in a real headless browser (Chromium): a screenshot renders its
//! figures, and the page asks the network for nothing. Every request goes through a local
//! proxy that records its host; the browser's own background requests (its updater, its
//! sign-in service) are those it also makes for a blank page, and a control page with an
//! outside image shows that the proxy sees a page's request.
//!
//! The browser is `DRIVE_CHROMIUM`, or `chromium` / `chromium-browser` / `google-chrome` on
//! the PATH (`.ci/run` installs Debian's `chromium`). Without one the test says so and
//! passes, unless `DRIVE_REQUIRE_BROWSER` is set (as `.ci/run` sets it).

use crate::common;
use common::ok;
use std::io::{Read, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

fn browser() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("DRIVE_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    let path = std::env::var_os("PATH")?;
    for dir in std::env::split_paths(&path) {
        for name in ["chromium", "chromium-browser", "google-chrome"] {
            let candidate = dir.join(name);
            if candidate.is_file() {
                return Some(candidate);
            }
        }
    }
    None
}

/// A proxy on loopback that answers 404 to everything and records each request's first line.
fn proxy() -> (u16, Arc<Mutex<Vec<String>>>) {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    let seen: Arc<Mutex<Vec<String>>> = Arc::default();
    let log = seen.clone();
    std::thread::spawn(move || {
        for stream in listener.incoming() {
            let Ok(mut stream) = stream else { continue };
            let _ = stream.set_read_timeout(Some(Duration::from_secs(2)));
            let mut buf = [0u8; 2048];
            let n = stream.read(&mut buf).unwrap_or(0);
            let first = String::from_utf8_lossy(&buf[..n])
                .lines()
                .next()
                .unwrap_or("(connection without a request)")
                .to_string();
            log.lock().unwrap().push(first);
            let _ = stream.write_all(
                b"HTTP/1.1 404 Not Found\r\nContent-Length: 0\r\nConnection: close\r\n\r\n",
            );
        }
    });
    (port, seen)
}

/// The host a proxied request line asks for (`CONNECT host:443 ...`, `GET http://host/...`).
fn host(line: &str) -> String {
    let target = line.split_whitespace().nth(1).unwrap_or_default();
    let target = target
        .strip_prefix("http://")
        .or_else(|| target.strip_prefix("https://"))
        .unwrap_or(target);
    let authority = target.split('/').next().unwrap_or_default();
    authority
        .rsplit_once(':')
        .map_or(authority, |(h, _)| h)
        .to_string()
}

/// The hosts requested since `from` requests were seen.
fn hosts_since(seen: &Mutex<Vec<String>>, from: usize) -> (usize, Vec<String>) {
    let seen = seen.lock().unwrap();
    let mut hosts: Vec<String> = seen[from..].iter().map(|l| host(l)).collect();
    hosts.sort();
    hosts.dedup();
    (seen.len(), hosts)
}

/// A headless screenshot of `page` through the proxy on `port`.
fn screenshot(browser: &Path, page: &Path, png: &Path, port: u16, profile: &Path) {
    let mut child = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-default-apps",
            "--hide-scrollbars",
            "--window-size=1400,6000",
            &format!("--user-data-dir={}", profile.display()),
            &format!("--proxy-server=http://127.0.0.1:{port}"),
            "--proxy-bypass-list=<-loopback>",
            &format!("--screenshot={}", png.display()),
            &format!("file://{}", page.display()),
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("the browser starts");
    let start = Instant::now();
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if start.elapsed() > Duration::from_secs(120) {
            let _ = child.kill();
            panic!("the browser did not finish within 120 s");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// The PNG's pixels as RGB.
fn pixels(png: &Path) -> (u32, u32, Vec<[u8; 3]>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(png).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    let step = info.color_type.samples();
    let px = buf[..info.buffer_size()]
        .chunks(step)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    (info.width, info.height, px)
}

#[test]
fn the_bench_page_renders_in_a_headless_browser_and_requests_nothing() {
    let Some(browser) = browser() else {
        assert!(
            std::env::var_os("DRIVE_REQUIRE_BROWSER").is_none(),
            "DRIVE_REQUIRE_BROWSER is set but no Chromium was found (DRIVE_CHROMIUM, or chromium on the PATH)"
        );
        eprintln!("skipped: no Chromium (install Debian's chromium, or set DRIVE_CHROMIUM)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let suite = d.join("suite.toml");
    std::fs::write(
        &suite,
        "[[dataset]]\nbundled = \"warthog_grass_2024-08-08\"\n\
         [[dataset]]\nbundled = \"warthog_asphalt_slow_2024-08-08\"\n",
    )
    .unwrap();
    let out = d.join("out");
    ok(&[
        "bench",
        "--suite",
        suite.to_str().unwrap(),
        "--models",
        "naive,slip-blr",
        "--out",
        out.to_str().unwrap(),
    ]);
    let (port, seen) = proxy();
    // What the browser asks for by itself: with a blank page.
    let blank = d.join("blank.html");
    std::fs::write(&blank, "<!DOCTYPE html><html><body></body></html>").unwrap();
    screenshot(&browser, &blank, &d.join("blank.png"), port, &d.join("p0"));
    let (n, mut browser_hosts) = hosts_since(&seen, 0);
    // The control: a page with an outside image is seen by the proxy.
    let control = d.join("control.html");
    std::fs::write(
        &control,
        "<!DOCTYPE html><html><body><img src=\"http://drive-test.invalid/x.png\"></body></html>",
    )
    .unwrap();
    screenshot(
        &browser,
        &control,
        &d.join("control.png"),
        port,
        &d.join("p1"),
    );
    let (n, control_hosts) = hosts_since(&seen, n);
    assert!(
        control_hosts.iter().any(|h| h == "drive-test.invalid"),
        "the proxy did not see the control page's request: {control_hosts:?}"
    );
    browser_hosts.extend(
        control_hosts
            .into_iter()
            .filter(|h| h != "drive-test.invalid"),
    );
    // The benchmark's page: nothing beyond the browser's own.
    let png = d.join("bench.png");
    screenshot(&browser, &out.join("bench.html"), &png, port, &d.join("p2"));
    let (_, page_hosts) = hosts_since(&seen, n);
    let extra: Vec<&String> = page_hosts
        .iter()
        .filter(|h| !browser_hosts.contains(h))
        .collect();
    assert!(
        extra.is_empty(),
        "the page made requests to {extra:?} (the browser alone: {browser_hosts:?})"
    );
    let (w, h, px) = pixels(&png);
    assert_eq!((w, h), (1400, 6000));
    // The figures drew: the first model's blue and the second's orange (the figures'
    // palette), and far from a blank page.
    let count = |c: [u8; 3]| px.iter().filter(|p| **p == c).count();
    assert!(
        count([31, 119, 180]) > 200,
        "blue pixels: {}",
        count([31, 119, 180])
    );
    assert!(
        count([255, 127, 14]) > 200,
        "orange pixels: {}",
        count([255, 127, 14])
    );
    let inked = px.iter().filter(|p| **p != [255, 255, 255]).count();
    assert!(
        inked > px.len() / 50,
        "{inked} of {} pixels drawn",
        px.len()
    );
}

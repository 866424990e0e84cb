//! End to end in a browser: the demo's page opened in headless Chromium (Debian's
//! `chromium`; `.ci/run` installs it when missing). Checks that the summary table and
//! every plot render (laid out with a size, with drawn elements), that the page logs no
//! console message, and saves a screenshot as `target/ncsmooth-demo-page.png`. Skips with
//! a loud message when no Chromium can be found (`NCSMOOTH_CHROMIUM` names one).
//!
//! How: a copy of the page gets a small script (the product page has none) that measures
//! the table and each `svg.plot` after load and writes the figures into the DOM, which
//! `--dump-dom` prints; `--enable-logging=stderr --v=0` prints every console message as an
//! `INFO:CONSOLE` line. A control page that logs an error shows the capture works.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("NCSMOOTH_CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    ["chromium", "chromium-browser", "google-chrome"]
        .iter()
        .find_map(|name| {
            std::env::var_os("PATH").and_then(|paths| {
                std::env::split_paths(&paths)
                    .map(|d| d.join(name))
                    .find(|p| p.is_file())
            })
        })
}

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ncsmooth-browser-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Runs headless Chromium on `page` with a fresh profile and `extra` arguments.
fn chrome(exe: &Path, profile: &Path, page: &Path, extra: &[&str]) -> Output {
    let mut c = Command::new(exe);
    c.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
    ])
    .arg(format!("--user-data-dir={}", profile.display()))
    .args(extra)
    .arg(format!("file://{}", page.display()));
    c.output().expect("running chromium")
}

/// The console messages Chromium logged (`INFO:CONSOLE` lines), ours excepted.
fn console_messages(stderr: &[u8]) -> Vec<String> {
    String::from_utf8_lossy(stderr)
        .lines()
        .filter(|l| l.contains(":CONSOLE"))
        .filter(|l| !l.contains("ncsmooth-check done"))
        .map(str::to_string)
        .collect()
}

/// Measures the page after load and writes the figures into `<pre id=ncsmooth-check>`.
const CHECK_SCRIPT: &str = r#"<script>
window.addEventListener('load', () => {
  const out = [];
  const t = document.getElementById('summary');
  out.push('table ' + (t ? t.rows.length : 0) + ' ' + (t ? Math.round(t.getBoundingClientRect().height) : 0));
  for (const svg of document.querySelectorAll('svg.plot')) {
    const b = svg.getBoundingClientRect();
    let drawn = 0;
    for (const e of svg.querySelectorAll('g[clip-path] path, g[clip-path] rect, g[clip-path] circle')) {
      const bb = e.getBBox();
      if (bb.width > 0 || bb.height > 0) drawn++;
    }
    out.push('plot ' + svg.id + ' ' + Math.round(b.width) + ' ' + Math.round(b.height) + ' ' + drawn);
  }
  const pre = document.createElement('pre');
  pre.id = 'ncsmooth-check';
  pre.textContent = out.join('\n');
  document.body.appendChild(pre);
  console.log('ncsmooth-check done');
});
</script>"#;

/// Virtual time Chromium gives the page before dumping it (ms).
const VIRTUAL_TIME_MS: &str = "--virtual-time-budget=5000";

#[test]
fn the_demo_page_renders_its_table_and_every_plot_in_chromium() {
    let Some(exe) = chromium() else {
        eprintln!(
            "SKIP the_demo_page_renders_its_table_and_every_plot_in_chromium: no chromium \
             found (apt-get install chromium, or set NCSMOOTH_CHROMIUM)"
        );
        return;
    };
    let d = tmpdir("demo");
    let o = Command::new(env!("CARGO_BIN_EXE_ncsmooth"))
        .current_dir(&d)
        .arg("--quiet")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let page = d.join("ncsmooth-demo/index.html");
    let html = std::fs::read_to_string(&page).unwrap();
    let plots = html.matches("class=\"plot\"").count();
    assert!(plots >= 10, "{plots} plots");

    // The capture works: a control page's console error is seen.
    let control = d.join("control.html");
    std::fs::write(&control, "<script>console.error('control error')</script>").unwrap();
    let c = chrome(
        &exe,
        &d.join("profile-control"),
        &control,
        &[
            "--enable-logging=stderr",
            "--v=0",
            VIRTUAL_TIME_MS,
            "--dump-dom",
        ],
    );
    assert!(
        console_messages(&c.stderr)
            .iter()
            .any(|l| l.contains("control error")),
        "the console capture does not work: {}",
        String::from_utf8_lossy(&c.stderr)
    );

    let check = d.join("ncsmooth-demo/check.html");
    std::fs::write(
        &check,
        html.replace("</body>", &format!("{CHECK_SCRIPT}</body>")),
    )
    .unwrap();
    let o = chrome(
        &exe,
        &d.join("profile-check"),
        &check,
        &[
            "--enable-logging=stderr",
            "--v=0",
            VIRTUAL_TIME_MS,
            "--dump-dom",
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let messages = console_messages(&o.stderr);
    assert!(messages.is_empty(), "console messages: {messages:#?}");
    let dom = String::from_utf8_lossy(&o.stdout);
    let report = dom
        .split("<pre id=\"ncsmooth-check\">")
        .nth(1)
        .and_then(|s| s.split("</pre>").next())
        .unwrap_or_else(|| panic!("the check did not run: {dom:.2000}"));
    let lines: Vec<&str> = report.lines().collect();
    let table: Vec<u32> = lines[0]
        .split(' ')
        .skip(1)
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(table[0], 6, "header and five methods: {report}");
    assert!(table[1] > 50, "the table has a height: {report}");
    let rendered: Vec<&&str> = lines.iter().filter(|l| l.starts_with("plot ")).collect();
    assert_eq!(rendered.len(), plots, "{report}");
    for l in rendered {
        let f: Vec<&str> = l.split(' ').collect();
        let (w, h, drawn): (u32, u32, u32) = (
            f[2].parse().unwrap(),
            f[3].parse().unwrap(),
            f[4].parse().unwrap(),
        );
        assert!(w >= 200 && h >= 150 && drawn >= 1, "plot not rendered: {l}");
    }
    eprintln!("chromium: table and {plots} plots rendered, no console message");

    let target = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target");
    let shot = target.join("ncsmooth-demo-page.png");
    let _ = std::fs::remove_file(&shot);
    let o = chrome(
        &exe,
        &d.join("profile-shot"),
        &page,
        &[
            "--window-size=1400,3200",
            &format!("--screenshot={}", shot.display()),
        ],
    );
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let png = std::fs::read(&shot).unwrap();
    assert!(
        png.starts_with(b"\x89PNG") && png.len() > 10_000,
        "{} bytes",
        png.len()
    );
    eprintln!("screenshot: {}", shot.display());
    let _ = std::fs::remove_dir_all(&d);
}

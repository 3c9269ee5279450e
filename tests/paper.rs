//! `--paper` outputs: the LaTeX tables compile with a real LaTeX (pdflatex, booktabs) and
//! every PDF figure renders (pdftoppm) to a page that is not blank. Needs Debian's
//! texlive-latex-recommended, librsvg2-bin and poppler-utils (`make paper-tools`).

use std::path::{Path, PathBuf};
use std::process::Command;

fn rockbench(args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_rockbench"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "rockbench {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

fn tool(name: &str) {
    let found = Command::new("sh")
        .args(["-c", &format!("command -v {name}")])
        .output()
        .is_ok_and(|o| o.status.success());
    assert!(found, "{name} is needed: run `make paper-tools`");
}

fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == ext))
        .collect();
    v.sort();
    v
}

/// Compile every table of `paper` in a minimal document; render every PDF figure.
fn check_paper(paper: &Path) {
    let tables = files(paper, "tex");
    let figures = files(paper, "pdf");
    assert!(
        !tables.is_empty() && !figures.is_empty(),
        "{}",
        paper.display()
    );
    for f in &figures {
        let svg = f.with_extension("svg");
        let csv = f.with_extension("csv");
        assert!(
            svg.is_file() && csv.is_file(),
            "{} lacks its SVG or CSV",
            f.display()
        );
    }
    assert!(paper.join("README.md").is_file());
    let readme = std::fs::read_to_string(paper.join("README.md")).unwrap();
    assert!(
        readme.contains("--paper")
            && readme.contains(&format!(
                "(commit {}, sources {})",
                rockbench::build_info::GIT_COMMIT,
                rockbench::build_info::SOURCE_HASH
            )),
        "{readme}"
    );
    let mut doc = String::from(
        "\\documentclass{article}\n\\usepackage[a3paper,landscape,margin=1cm]{geometry}\n\\usepackage{booktabs}\n\\usepackage{graphicx}\n\\begin{document}\n",
    );
    for t in &tables {
        doc += &format!(
            "\\begin{{table}}[p]\\centering\\resizebox{{\\textwidth}}{{!}}{{\\input{{{}}}}}\\end{{table}}\n",
            t.display()
        );
    }
    for f in &figures {
        doc += &format!(
            "\\includegraphics[width=0.45\\textwidth]{{{}}}\n",
            f.display()
        );
    }
    doc += "\\end{document}\n";
    let build = paper.join("latex-check");
    std::fs::create_dir_all(&build).unwrap();
    std::fs::write(build.join("doc.tex"), doc).unwrap();
    let out = Command::new("pdflatex")
        .args(["-interaction=nonstopmode", "-halt-on-error", "doc.tex"])
        .current_dir(&build)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "pdflatex failed on {}: {}",
        paper.display(),
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter(|l| l.starts_with('!') || l.starts_with("l."))
            .collect::<Vec<_>>()
            .join(" | ")
    );
    assert!(build.join("doc.pdf").is_file());
    for f in &figures {
        let png = build.join(f.file_stem().unwrap());
        let out = Command::new("pdftoppm")
            .args(["-png", "-r", "40", "-singlefile"])
            .arg(f)
            .arg(&png)
            .output()
            .unwrap();
        assert!(out.status.success(), "pdftoppm {}", f.display());
        let png = png.with_extension("png");
        let decoder = png::Decoder::new(std::fs::File::open(&png).unwrap());
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        let bytes = &buf[..info.buffer_size()];
        let dark = bytes
            .chunks(3)
            .filter(|p| p.iter().any(|c| *c < 128))
            .count();
        let total = bytes.len() / 3;
        assert!(
            dark > total / 500 && dark < total / 2,
            "{}: {dark} of {total} pixels drawn",
            f.display()
        );
    }
}

#[test]
fn paper_outputs_compile_and_render() {
    for t in ["pdflatex", "pdftoppm", "rsvg-convert"] {
        tool(t);
    }
    let conv = scratch("paper-converge");
    rockbench(&[
        "converge",
        "validation/scenes/housner-square.toml",
        "--engines",
        "native",
        "--dt",
        "2e-3,1e-3,5e-4",
        "--reference",
        "housner",
        "--set",
        "duration=0.4",
        "--paper",
        "--out",
        conv.to_str().unwrap(),
    ]);
    for f in ["converge.csv", "orders.csv", "converge.md", "converge.json"] {
        assert!(conv.join(f).is_file(), "{f}");
    }
    check_paper(&conv.join("paper"));
    let cmp = scratch("paper-compare");
    rockbench(&[
        "compare",
        "validation/scenes/two-block-free-rocking.toml",
        "--engines",
        "native",
        "--reference",
        "native",
        "--set",
        "duration=1",
        "--set",
        "native.stepper=\"impact\"",
        "--quiet",
        "--paper",
        "--out",
        cmp.to_str().unwrap(),
    ]);
    check_paper(&cmp.join("paper"));
    let tables: Vec<String> = files(&cmp.join("paper"), "tex")
        .iter()
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(tables, ["impact-times", "rest-times", "settings"]);
    let val = scratch("paper-validate");
    rockbench(&[
        "validate",
        "validation/suite.toml",
        "--gates",
        "validation/gates.toml",
        "--case",
        "two-block-free-rocking",
        "--engines",
        "native",
        "--no-cache",
        "--quiet",
        "--paper",
        "--out",
        val.to_str().unwrap(),
    ]);
    check_paper(&val.join("paper"));
    assert!(val.join("paper/validation-matrix.tex").is_file());
}

//! The report's renderings for humans: Markdown (checked into shaders-out/)
//! and plain text (`inspect`).

use super::*;

impl Report {
    /// A Markdown rendering for humans (checked into shaders-out/).
    pub fn to_markdown(&self) -> String {
        let mut s = String::new();
        let v = |q: &QVec| format!("({})", q.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "));
        let iv = |q: &IVec| format!("({})", q.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "));
        let _ = writeln!(s, "# {}\n\n{}\n", self.name, self.description);
        let _ = writeln!(s, "| fact | value |\n|---|---|");
        let rows = [
            (
                "lattice",
                format!(
                    "{} (generators {}, \\|det G\\| = {})",
                    self.lattice,
                    self.lattice_generators.iter().map(iv).collect::<Vec<_>>().join(" "),
                    self.lattice_det
                ),
            ),
            ("directions", self.directions.iter().map(iv).collect::<Vec<_>>().join(" ")),
            ("degree", self.degree.to_string()),
            ("approximation order", self.approximation_order.to_string()),
            ("continuity", format!("C^{}", self.continuity)),
            ("smoothness", smoothness(self.continuity, self.degree)),
            ("support volume", self.support_volume.to_string()),
            ("grid offset", v(&self.grid_offset)),
            (
                "cube classes",
                format!(
                    "{}: {}",
                    self.cube_classes,
                    self.cube_class_corners.iter().map(iv).collect::<Vec<_>>().join(" ")
                ),
            ),
            ("evaluation cells per fundamental domain", self.cells_per_fundamental_domain.to_string()),
            ("polynomial pieces per fundamental domain", self.polynomial_pieces_per_fundamental_domain.to_string()),
            ("symmetry order", self.symmetry_order.to_string()),
            ("reference pieces", self.reference_pieces.len().to_string()),
            ("max stencil", self.max_stencil_size.to_string()),
            (
                "polynomials (reference pieces x stencil)",
                format!(
                    "{} (estimated {} before cutting: {} reference pieces x {} mean stencil){}",
                    self.work.polynomials,
                    self.work.estimate.polynomials,
                    self.work.estimate.reference_pieces,
                    self.work.estimate.stencil,
                    if self.work.coefficients_listed {
                        ""
                    } else {
                        "; coefficients not listed (over the report limit)"
                    }
                ),
            ),
        ];
        for (k, val) in rows {
            let _ = writeln!(s, "| {k} | {val} |");
        }
        let _ = writeln!(s, "\n## Knot planes\n\n| normal n | n.x in |\n|---|---|");
        for k in &self.knot_planes {
            let _ = writeln!(s, "| {} | {} + {}Z |", iv(&k.normal), k.offset, k.period);
        }
        let _ = writeln!(s, "\n## Cells and their maps g(x) = R x + t onto reference pieces\n");
        let _ = writeln!(s, "| cell | class | vertices | reference | R (rows) | t |\n|---|---|---|---|---|---|");
        for (i, c) in self.cells.iter().enumerate().take(200) {
            let _ = writeln!(
                s,
                "| {i} | {} | {} | {} | {} | {} |",
                c.class,
                c.vertices.iter().map(v).collect::<Vec<_>>().join(" "),
                c.reference,
                c.rotation.iter().map(iv).collect::<Vec<_>>().join(" "),
                iv(&c.translation)
            );
        }
        if self.cells.len() > 200 {
            let _ = writeln!(s, "\n({} more cells in the JSON report)", self.cells.len() - 200);
        }
        for (i, r) in self.reference_pieces.iter().enumerate() {
            let _ = writeln!(s, "\n## Reference piece {i}\n");
            let _ = writeln!(
                s,
                "{} in the cube with corner {}, orbit of {} cells.\n\nVertices: {}\n",
                if r.is_simplex { "Simplex" } else { "Polytope" },
                iv(&r.corner),
                r.cells_in_orbit,
                r.vertices.iter().map(v).collect::<Vec<_>>().join(" ")
            );
            let _ = writeln!(s, "Stencil ({} samples, offsets from the cube corner):\n", r.stencil.len());
            for k in &r.stencil {
                let _ = writeln!(s, "- {}", iv(k));
            }
            if r.is_simplex {
                let _ = writeln!(s, "\nBB coefficients b_alpha = sum w c(offset):\n\n| alpha | weights |\n|---|---|");
                for b in &r.bb {
                    let ws: Vec<String> = b.weights.iter().map(|w| format!("{} c{}", w.w, iv(&w.offset))).collect();
                    let idx: Vec<String> = b.index.iter().map(|x| x.to_string()).collect();
                    let _ = writeln!(s, "| {} | {} |", idx.join(""), ws.join(" + "));
                }
            } else {
                let _ = writeln!(s, "\nNot a simplex: the power form (in the JSON report) is used.");
            }
        }
        let e = &self.evaluation;
        let _ = writeln!(
            s,
            "\n## Evaluation in the shaders\n\nPoint location: {}, {} candidate cell(s) after locating. {} fetches per evaluation; {} vector adds walk the fetch positions (a matrix-vector product per fetch would cost {}).\n\nFetch order (offsets q from the frame base, x = b + M q):\n",
            e.locate, e.candidates, e.fetches_per_eval, e.vector_adds, e.matvec_adds
        );
        let _ = writeln!(s, "{}", e.fetch_order.iter().map(iv).collect::<Vec<_>>().join(" → "));
        if !self.shaders.is_empty() {
            let _ = writeln!(s, "\n| layout | variant | form | fetches/eval | vector adds | ops in eval | ops in eval_grad | eval_hessian form | ops in eval_hessian |\n|---|---|---|---|---|---|---|---|---|");
            for st in self.shaders.iter().map(|sr| &sr.stats) {
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                    st.layout.name(),
                    st.variant.name(),
                    st.form.name(),
                    st.fetches_per_eval,
                    st.vector_adds,
                    st.ops_eval,
                    st.ops_eval_grad,
                    st.hessian_form.map_or("none", |f| f.name()),
                    st.ops_eval_hessian.map_or("-".to_string(), |n| n.to_string())
                );
            }
            let _ = writeln!(s, "\n(ops: operators, comparisons, selects and builtin calls in the WGSL source; the naive variant's loops are counted once. The naive variant keeps the dense form: it measures branches and lookup tables.)");
            if let Some(st) = self.shaders.iter().map(|sr| &sr.stats).find(|st| st.variant.name() == "fast") {
                let _ = writeln!(
                    s,
                    "\n### Evaluation forms\n\nThe generator emits every exact form available for this filter and keeps the cheapest by its cost model (ops in eval + ops in eval_grad; exact loads are the same for every form). Chosen: **{}**.\n\n| form | fetches | ops in eval | ops in eval_grad | cost |\n|---|---|---|---|---|",
                    st.form.name()
                );
                for f in &st.forms {
                    let _ = writeln!(
                        s,
                        "| {} | {} | {} | {} | {} |",
                        f.form.name(),
                        f.fetches,
                        f.ops_eval,
                        f.ops_eval_grad,
                        f.cost()
                    );
                }
            }
        }
        if !self.shaders.is_empty() {
            let _ = writeln!(
                s,
                "\n### Bindings\n\nRead from each validated module (naga). Used by: entry points, and the functions no other function calls (the module's API).\n\n| layout | variant | fetch | group | binding | name | kind | format | used by | host puts there |\n|---|---|---|---|---|---|---|---|---|---|"
            );
            for sr in &self.shaders {
                for b in &sr.bindings {
                    let used: Vec<&str> = b.entry_points.iter().chain(&b.functions).map(String::as_str).collect();
                    let _ = writeln!(
                        s,
                        "| {} | {} | {} | {} | {} | `{}` | `{}` | {} | {} | {} |",
                        sr.stats.layout.name(),
                        sr.stats.variant.name(),
                        sr.stats.fetch.name(),
                        b.group,
                        b.binding,
                        b.name,
                        b.kind,
                        b.format.as_ref().map(|f| format!("`{f}`")).unwrap_or_else(|| "-".into()),
                        if used.is_empty() { "-".to_string() } else { used.join(", ") },
                        b.purpose.as_deref().unwrap_or("-")
                    );
                }
            }
        }
        if let Some(l) = &self.linear_fetch {
            let _ = writeln!(
                s,
                "\n### Linear fetches\n\n`fetch = linear` (Builder::fetch): {} hardware-filtered fetches instead of {} exact loads in eval. CPU emulation of the hardware interpolation at {} random points on random data in [0, 1]: max error {:.1e} with float weights (lavapipe), {:.1e} (RMS {:.1e}) with weights rounded to 8 fractional bits (typical GPU texture units).",
                l.fetches, l.exact_loads, l.points, l.max_error_float_weights, l.max_error_8bit_weights, l.rms_error_8bit_weights
            );
        }
        if let Some(l) = &self.linear_fetch_packed {
            let p = &l.non_negative;
            let _ = writeln!(
                s,
                "\n### Linear fetches, packed layout\n\n`fetch = linear` with `layout = packed`: {} hardware-filtered fetches instead of {} exact loads in eval (pairs of samples adjacent in one coset's grid, a maximum matching per reference piece). Weights non-negative: {} of {} by their Bernstein-Bezier coefficients (exact), {} by the box-spline theorem. CPU emulation at {} random points on random data in [0, 1]: max error {:.1e} with float weights (lavapipe), {:.1e} (RMS {:.1e}) with weights rounded to 8 fractional bits.",
                l.fetches, l.exact_loads, p.by_bernstein_coefficients, p.weights, p.by_box_spline_theorem, l.points, l.max_error_float_weights, l.max_error_8bit_weights, l.rms_error_8bit_weights
            );
        }
        let _ = writeln!(
            s,
            "\n## Quasi-interpolation prefilter\n\n{} taps in {} shells.\n\n| offset | weight |\n|---|---|",
            self.prefilter.len(),
            self.prefilter_shells
        );
        for w in &self.prefilter {
            let _ = writeln!(s, "| {} | {} |", iv(&w.offset), w.w);
        }
        s
    }

    /// A readable summary for terminals.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let v = |q: &QVec| format!("({})", q.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "));
        let iv = |q: &IVec| format!("({})", q.iter().map(|x| x.to_string()).collect::<Vec<_>>().join(", "));
        let _ = writeln!(s, "{} — {}", self.name, self.description);
        let _ = writeln!(
            s,
            "  lattice           {} (|det G| = {}), dimension {}",
            self.lattice, self.lattice_det, self.dimension
        );
        let _ = writeln!(s, "  directions        {}", self.directions.iter().map(iv).collect::<Vec<_>>().join(" "));
        let _ = writeln!(
            s,
            "  degree {}, approximation order {}, continuity C^{}",
            self.degree, self.approximation_order, self.continuity
        );
        let _ = writeln!(s, "  smoothness        {}", smoothness(self.continuity, self.degree));
        let _ = writeln!(s, "  support volume    {}", self.support_volume);
        let _ = writeln!(s, "  knot planes       {} families:", self.knot_planes.len());
        for k in &self.knot_planes {
            let _ = writeln!(s, "    n = {:<14} n.x in {} + {}Z", iv(&k.normal), k.offset, k.period);
        }
        let _ = writeln!(s, "  grid offset       {}", v(&self.grid_offset));
        let _ = writeln!(
            s,
            "  cube classes      {}: {}",
            self.cube_classes,
            self.cube_class_corners.iter().map(iv).collect::<Vec<_>>().join(" ")
        );
        let _ = writeln!(s, "  evaluation cells  {} per fundamental domain", self.cells_per_fundamental_domain);
        let _ =
            writeln!(s, "  polynomial pieces {} per fundamental domain", self.polynomial_pieces_per_fundamental_domain);
        let _ = writeln!(s, "  symmetry order    {}", self.symmetry_order);
        let _ =
            writeln!(s, "  reference pieces  {} (max stencil {})", self.reference_pieces.len(), self.max_stencil_size);
        let _ = writeln!(
            s,
            "  polynomials       {} (estimated {} before cutting){}",
            self.work.polynomials,
            self.work.estimate.polynomials,
            self.derivation_seconds.map(|t| format!(", derived in {t:.2} s")).unwrap_or_default()
        );
        for (i, r) in self.reference_pieces.iter().enumerate().take(64) {
            let _ = writeln!(
                s,
                "    #{i}: {} with {} vertices in cube {}, orbit of {} cells, stencil {}, {}",
                if r.is_simplex { "simplex" } else { "polytope" },
                r.vertices.len(),
                iv(&r.corner),
                r.cells_in_orbit,
                r.stencil.len(),
                if r.is_simplex { format!("{} BB coefficients", r.bb.len()) } else { "power form".to_string() }
            );
            let _ = writeln!(s, "        vertices: {}", r.vertices.iter().map(v).collect::<Vec<_>>().join(" "));
        }
        if self.reference_pieces.len() > 64 {
            let _ = writeln!(s, "    ({} more in the JSON report)", self.reference_pieces.len() - 64);
        }
        let _ = writeln!(s, "  prefilter         {} taps in {} shells:", self.prefilter.len(), self.prefilter_shells);
        for w in &self.prefilter {
            let _ = writeln!(s, "    {} {}", iv(&w.offset), w.w);
        }
        s
    }
}

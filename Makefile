# slamlab — the two commands: `make report` and `make test`.
# Every target uses the release profile, so one (slow, ~10–15 min) polars build serves them all.

CARGO ?= cargo
BIN   := $(or $(CARGO_TARGET_DIR),target)/release/slamlab
SPECS := $(sort $(wildcard experiments/*.toml))
MDBOOK ?= mdbook
MDBOOK_VERSION := 0.4.52

.PHONY: all build report run test test-slurm memcheck bench validate clean-results check-reports check-html pdf install-checkers docs check-docs install-mdbook

all: report

## Checks (and, as root or with sudo, installs) the C/C++ compilers, make and cmake first.
build:
	tests/tools/build_tools.sh
	$(CARGO) build --release --locked

## Run every study in experiments/ (cached, parallel, deterministic) and render reports/; the
## README's fidelity block is then refreshed from reports/fidelity/summary.md.
report: build
	tests/tools/python_deps.sh
	$(BIN) run $(SPECS)
	$(BIN) report --specs experiments
	tests/tools/readme_block.sh write README.md reports/fidelity/summary.md
	$(BIN) docs docs/src/reference

## Only (re)run the studies, without rendering.
run: build
	tests/tools/python_deps.sh
	$(BIN) run $(SPECS)

validate: build
	$(BIN) validate $(SPECS)

## Formatting (rustfmt.toml), unit and integration tests (and the benchmarks must compile); the
## external-algorithm tests need python3 with numpy (installed when missing). The dependency
## features of the test build equal the release build's (checked first), so after `make report` no dependency is
## compiled again.
test:
	tests/tools/build_tools.sh
	tests/tools/python_deps.sh
	$(CARGO) fmt --check
	tests/tools/features_unified.sh
	$(CARGO) test --release --locked
	$(CARGO) build --release --locked --benches

## `slamlab slurm` on a real one-node Slurm cluster started here (installs slurm-wlm and munge
## when missing; needs root or sudo): a job array of 4 shards with one task killed and resumed,
## byte-identical to a single-process run.
test-slurm: build
	tests/tools/test_slurm.sh

## One TNEWTON run under valgrind's memcheck (installs valgrind when missing): fails on any use
## of memory NLopt has not written (build/nlopt_patch.rs). About 10 s.
memcheck: build
	tests/tools/memcheck_tnewton.sh $(BIN)

## Benchmarks: criterion micro-benchmarks, then the whole pipeline from scratch.
bench: build
	$(CARGO) bench --locked --bench world --bench slam --bench landmark_filters --bench scanmatch --bench graph_slam --bench fastslam_scaling
	tests/tools/plan_bench.sh $(BIN)
	tests/tools/memory_bench.sh $(BIN)
	tests/tools/report_bench.sh $(BIN)
	@tmp=$$(mktemp -d); \
	start=$$(date +%s.%N); \
	$(BIN) run --quiet --results $$tmp/results --cache $$tmp/cache $(SPECS); \
	mid=$$(date +%s.%N); \
	$(BIN) run --quiet --results $$tmp/results --cache $$tmp/cache $(SPECS); \
	cached=$$(date +%s.%N); \
	$(BIN) report --results $$tmp/results --out $$tmp/reports 2>/dev/null; \
	end=$$(date +%s.%N); \
	runs=$$(for s in $(SPECS); do $(BIN) plan $$s --results $$tmp/results --cache $$tmp/cache | tail -1; done | awk '{n+=$$NF} END {print n}'); \
	awk -v a=$$start -v b=$$mid -v c=$$cached -v d=$$end -v n=$$runs 'BEGIN { \
	  printf "pipeline: %d runs of %d studies from scratch in %.2f s; all cached in %.2f s; reports rendered in %.2f s\n", n, $(words $(SPECS)), b-a, c-b, d-c }'; \
	rm -rf $$tmp

## Regenerate the reports from the results into a temporary folder and compare them, byte for
## byte, with the committed reports/, and the README's fidelity block with the regenerated
## scoreboard (run `make run` first on a fresh clone). The book includes the scoreboard's margins
## table from reports/fidelity/margins.md itself.
check-reports: build
	@tmp=$$(mktemp -d); trap 'rm -rf "$$tmp"' EXIT; \
	cp -r reports "$$tmp/reports"; \
	$(BIN) report --specs experiments --out "$$tmp/reports" >/dev/null || exit 1; \
	if diff -r reports "$$tmp/reports" >/dev/null; then echo "check-reports: reports/ is up to date"; \
	else diff -rq reports "$$tmp/reports"; echo "check-reports: reports/ differs from what the results give (make report)" >&2; exit 1; fi; \
	tests/tools/readme_block.sh check README.md "$$tmp/reports/fidelity/summary.md"

## Open every report in headless Chromium: console errors or missing images fail (screenshots in
## target/reports-html/). Needs Debian's chromium.
check-html:
	tests/tools/check_html.sh reports target/reports-html

## Compile every study's .tex to PDF with pdflatex (into target/reports-pdf/). Needs texlive.
pdf:
	tests/tools/pdf.sh reports target/reports-pdf

## Install what check-html and pdf need (Debian/Ubuntu, with apt; about 1 GB).
install-checkers:
	@SUDO=""; [ "$$(id -u)" -ne 0 ] && SUDO="sudo"; \
	$$SUDO apt-get update -q && $$SUDO apt-get install -y -q --no-install-recommends chromium texlive-latex-extra texlive-pictures texlive-science lmodern

## The book (docs/, mdBook): regenerate its generated chapters (command line, algorithms) and
## build it into target/book (open target/book/index.html). Needs mdBook (make install-mdbook).
docs: build
	$(BIN) docs docs/src/reference
	$(MDBOOK) build docs

## The generated chapters are current, every relative link of the README and the book resolves,
## the README has at most 250 lines, and the book builds (tests/tools/check_docs.sh; runs in CI).
check-docs: build
	MDBOOK=$(MDBOOK) tests/tools/check_docs.sh

## mdBook, pinned, from crates.io (into ~/.cargo/bin) when it is not already installed.
install-mdbook:
	@command -v $(MDBOOK) >/dev/null && $(MDBOOK) --version | grep -q "v$(MDBOOK_VERSION)" || \
	  $(CARGO) install mdbook --version $(MDBOOK_VERSION) --locked

## Remove generated results and the run cache (reports/ is committed and stays).
clean-results:
	rm -rf data/results data/cache

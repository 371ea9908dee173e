# Shell helpers shared by the thread-count scripts, parallel-ceiling.sh and scaling-curve.sh
# (sourced, not run).

# Sets $bin from the first argument (default target/release/magopt), or exits 1 with a
# one-line message when there is no binary there.
magopt_bin() {
    bin=${1:-target/release/magopt}
    [ -x "$bin" ] || { echo "no magopt binary at $bin (cargo build --release first)" >&2; exit 1; }
}

# The bed's and align's N = 1e4 workloads, "name|magopt arguments" (each script adds its blast).
n1e4_workloads=(
    "bed N=1e4, 3000 steps|bed --json --particles 10000 --max-steps 3000"
    "align N=1e4|align --json --particles 10000"
)

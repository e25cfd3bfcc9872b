#!/usr/bin/env bash
# Launch a cavesim cluster: a master and its nodes, on this machine or on several hosts. A
# node draws one wall, or the walls the CAVE file gives it with `node = NAME`.
#
#   deploy/launch.sh [--hosts FILE] [--walls N | --cave FILE] [--display] [--scene FILE]
#                    [--group-by cave|wall|gpu] [--frames F] [--out DIR] [--session NAME]
#                    [--keys DIR] [--max-lag SECONDS]
#                    [--config FILE] [--realtime] [--mixed-hardware] [--insecure]
#                    [--dry-run]
#
# Without --hosts everything runs here: this execs `.venv/bin/cavesim run --walls N ...`
# (or `--cave FILE`, and --group-by, as `cavesim run --help` says; after deploy/setup.sh if
# .venv is missing), which writes OUT/report.json. --display shows every wall live in its window, as the CAVE file's
# [wall.display] tables say (needs --cave), swap-locked.
#
# With --hosts FILE the processes start where the file says. Hosts file format (see
# config/cluster/hosts.example), one entry per line, '#' starts a comment, blank lines
# are ignored:
#
#   master HOST[:PORT]  [via=COMMAND]    exactly one; PORT defaults to 7447
#   node   NAME HOST    [via=COMMAND]    one per node; NAME is a wall's name, or the name
#                                        of a node that the CAVE file gives several walls
#
# via=COMMAND is how to run a command on that host; the default is
# `ssh -tt -o BatchMode=yes HOST` (-tt: when the launcher stops its ssh client, the remote
# process is hung up too; BatchMode: fail instead of waiting for a password nobody can
# type). Quote a COMMAND with spaces: via="ip netns exec wall1". An empty via= runs the
# command directly on this machine. The command is appended as separate words, and ssh
# joins words with spaces, so every path and name given here must be free of spaces and
# shell characters (the script checks).
#
# On each node host it runs
#   $CAVESIM_REMOTE node --node NAME --scene S --session NAME --connect tcp/MASTER:PORT
#                        --listen tcp/0.0.0.0:0 --verbose [--key-file K/wall-NAME.key]
#                        [--config Z]
#                        [--cave C --display]
# and on the master host `mkdir -p OUT`, then
#   $CAVESIM_REMOTE master --walls NAME,NAME,... --listen tcp/0.0.0.0:PORT --frames F
#                          --report OUT/report.json --frame-log OUT/frames.log ...
#                          [--realtime]
# CAVESIM_REMOTE is the cavesim command on the hosts (default: `cavesim` on the PATH).
# With --display each node opens its walls' window (side by side) on the X display the
# first one's [wall.display] x_display names (e.g. ":0"), else on the DISPLAY its command gets (via="ssh -tt HOST
# env DISPLAY=:0"); C is the CAVE file's path on the hosts.
# Hosts mode only: --config Z gives every process that zenoh JSON5 file, e.g.
# config/zenoh/multihost.json5 (a short lease and fast reconnects for a LAN; the endpoints
# still come from the hosts file), and --realtime has the master pace frames by the wall
# clock, as a CAVE's displays need (default: as fast as the barrier allows).
# --max-lag SECONDS goes to the master (or `cavesim run`): a wall whose report of a frame
# comes that long after half the walls' is named, and given up when it does so too often
# (docs/guide/running-a-cave.md; default 1 s, 0.1 on a CAVE whose GPUs keep 60 Hz).
# --keys DIR signs every message: DIR holds what `cavesim keys --out DIR --walls ...` made
# for the node names; the master reads DIR/master.key (on the master host only), each node
# its own DIR/wall-NAME.key (which cannot sign frames or commands, nor speak for another
# node).
# With --hosts the messages cross a network, so --keys is required; --insecure runs
# unsigned anyway (anyone on that network can then steer, stop or forge the run). The scene, OUT, DIR and Z are paths on the hosts (relative ones are resolved by
# the remote command: the login directory for ssh; a scene also by the cavesim checkout).
# Node output is collected here in OUT/logs/NAME.log; the master's goes to the terminal.
# The launcher waits for the master, exits with its status, and on exit or Ctrl-C stops
# every node process it started. --mixed-hardware runs the master and every node in the
# tolerance mode for walls whose GPUs round differently (docs/guide/mixed-hardware.md; the first
# wall is the authority). --dry-run prints the commands instead of running them.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
me="launch.sh"
DEFAULT_PORT=7447  # = cavesim.core.limits.DEFAULT_MASTER_PORT (tests/processes/test_launch.py checks it)

usage() {
    echo "usage: deploy/launch.sh [--hosts FILE] [--walls N | --cave FILE] [--display]" \
         "[--scene FILE] [--group-by cave|wall|gpu] [--frames F] [--out DIR]" \
         "[--session NAME] [--keys DIR] [--max-lag SECONDS]" \
         "[--config FILE] [--realtime] [--mixed-hardware] [--insecure] [--dry-run]" >&2
    echo "(the comment at the top of deploy/launch.sh explains them and the hosts file)" >&2
    exit 2
}

die() {  # a usage or input error: one line, exit 2
    echo "$me: error: $*" >&2
    exit 2
}

hosts_file="" walls="" scene="config/scenes/brownout.toml" frames=600 out=""
session="run" keys="" zenoh_config="" realtime=0 dry_run=0 cave="" display=0 mixed=0
insecure=0 group_by="" max_lag=""
while (($#)); do
    case "$1" in
        --hosts | --walls | --scene | --frames | --out | --session | --keys | --config \
            | --cave | --group-by | --max-lag)
            (($# >= 2)) || die "argument $1: expected a value"
            case "$1" in
                --hosts) hosts_file="$2" ;;
                --walls) walls="$2" ;;
                --scene) scene="$2" ;;
                --frames) frames="$2" ;;
                --out) out="$2" ;;
                --session) session="$2" ;;
                --keys) keys="${2%/}" ;;
                --config) zenoh_config="$2" ;;
                --cave) cave="$2" ;;
                --group-by) group_by="$2" ;;
                --max-lag) max_lag="$2" ;;
            esac
            shift 2 ;;
        --realtime) realtime=1; shift ;;
        --display) display=1; shift ;;
        --mixed-hardware) mixed=1; shift ;;
        --insecure) insecure=1; shift ;;
        --dry-run) dry_run=1; shift ;;
        -h | --help) usage ;;
        *) die "unknown argument $1 (see deploy/launch.sh --help)" ;;
    esac
done

[[ -z "$walls" || "$walls" =~ ^[1-9][0-9]*$ ]] \
    || die "argument --walls: expected a number >= 1, got '$walls'"
[[ "$frames" =~ ^[1-9][0-9]*$ ]] || die "argument --frames: expected a number >= 1, got '$frames'"
[[ -z "$max_lag" || "$max_lag" =~ ^[0-9]+(\.[0-9]+)?$ ]] \
    || die "argument --max-lag: expected seconds (e.g. 0.1), got '$max_lag'"
((!display)) || [ -n "$cave" ] || die "argument --display: needs --cave FILE (the walls' windows)"
[ ! -e "$out" ] || [ -d "$out" ] \
    || die "argument --out: '$out' is a file; give a folder (a new one is made)"

show() {  # print a command as one line that a shell would read back the same way
    local line="" word
    for word in "$@"; do
        [[ "$word" =~ ^[A-Za-z0-9._/:@%+=,~-]+$ ]] || word="$(printf '%q' "$word")"
        line+="${line:+ }$word"
    done
    printf '%s\n' "$line"
}

# -- one machine: `cavesim run` does it all ---------------------------------------------------

if [ -z "$hosts_file" ]; then
    [ -z "$zenoh_config" ] \
        || die "argument --config: only with --hosts (one machine runs on loopback)"
    ((!realtime)) || die "argument --realtime: only with --hosts"
    [ -z "$cave" ] || [ -z "$walls" ] \
        || die "argument --walls: not with --cave (the CAVE names its walls)"
    command=("$root/.venv/bin/cavesim" run --scene "$scene" --frames "$frames"
             --session "$session")
    [ -z "$out" ] || command+=(--out "$out")  # else a fresh folder under out/
    if [ -n "$cave" ]; then command+=(--cave "$cave"); else command+=(--walls "${walls:-4}"); fi
    ((!display)) || command+=(--display)
    [ -z "$group_by" ] || command+=(--group-by "$group_by")
    ((!mixed)) || command+=(--mixed-hardware)
    [ -z "$max_lag" ] || command+=(--max-lag "$max_lag")
    [ -z "$keys" ] || command+=(--key-file "$keys/master.key")
    if ((dry_run)); then
        [ -x "$root/.venv/bin/cavesim" ] || show "$root/deploy/setup.sh"
        show "${command[@]}"
        exit 0
    fi
    [ -x "$root/.venv/bin/cavesim" ] || "$root/deploy/setup.sh"
    exec "${command[@]}"
fi
out="${out:-out}"  # on the master's host: its report and frame log, and the node logs here

# -- several hosts: read and check the hosts file ---------------------------------------------

[ -f "$hosts_file" ] || die "argument --hosts: no such file '$hosts_file'"
[ -z "$group_by" ] \
    || die "argument --group-by: only without --hosts (the hosts file names the nodes)"

master_host="" master_port="" master_via=() master_line=0
node_names=() node_hosts=() node_lines=() node_vias=()

choose_via() {  # choose_via HOST: this line's via= (or ssh to HOST) as words in `via_words`
    via_words=()
    if ((via_given)); then
        [ -z "$via" ] || read -r -a via_words <<<"$via"
    else
        via_words=(ssh -tt -o BatchMode=yes "${1//[\[\]]/}")  # ssh wants IPv6 without [ ]
    fi
}

number=0
while IFS= read -r raw || [ -n "$raw" ]; do
    number=$((number + 1))
    where="$hosts_file:$number"
    line="${raw%%#*}"
    via_given=0 via=""
    if [[ "$line" =~ ^(.*[[:space:]])via=(.*)$ ]]; then
        line="${BASH_REMATCH[1]}" via="${BASH_REMATCH[2]}" via_given=1
        via="${via#"${via%%[![:space:]]*}"}" via="${via%"${via##*[![:space:]]}"}"  # trim
        if [[ "$via" =~ ^\"(.*)\"$ || "$via" =~ ^\'(.*)\'$ ]]; then via="${BASH_REMATCH[1]}"; fi
    fi
    read -r -a fields <<<"$line"
    ((${#fields[@]})) || continue
    case "${fields[0]}" in
        master)
            ((${#fields[@]} == 2)) \
                || die "$where: expected 'master HOST[:PORT] [via=COMMAND]', got '$raw'"
            ((master_line == 0)) || die "$where: a second master (the first is line $master_line)"
            [[ "${fields[1]}" =~ ^(\[[0-9A-Fa-f:.]+\]|[^:[]+)(:([0-9]+))?$ ]] \
                || die "$where: expected HOST or HOST:PORT, got '${fields[1]}'"
            master_host="${BASH_REMATCH[1]}" master_port="${BASH_REMATCH[3]:-$DEFAULT_PORT}"
            ((10#$master_port >= 1 && 10#$master_port <= 65535)) \
                || die "$where: port must be 1..65535, got $master_port"
            master_line=$number
            choose_via "$master_host"
            master_via=("${via_words[@]}")
            ;;
        node)
            ((${#fields[@]} == 3)) \
                || die "$where: expected 'node NAME HOST [via=COMMAND]', got '$raw'"
            name="${fields[1]}" host="${fields[2]}"
            [[ "$name" =~ ^[A-Za-z0-9_-]{1,32}$ ]] \
                || die "$where: node name must be 1-32 letters, digits, '_' or '-', got '$name'"
            for i in "${!node_names[@]}"; do
                [ "${node_names[$i]}" != "$name" ] \
                    || die "$where: node '$name' appears twice (first on line ${node_lines[$i]})"
            done
            choose_via "$host"
            node_names+=("$name") node_hosts+=("$host") node_lines+=("$number")
            node_vias+=("$(show "${via_words[@]}")")  # kept as one shell-quoted line
            ;;
        *) die "$where: unknown role '${fields[0]}' (expected 'master' or 'node')" ;;
    esac
done <"$hosts_file"

((master_line)) || die "$hosts_file: no 'master HOST[:PORT]' line"
((${#node_names[@]})) || die "$hosts_file: no 'node NAME HOST' line"
[ -z "$walls" ] || ((walls == ${#node_names[@]})) \
    || die "argument --walls: $walls walls, but $hosts_file names ${#node_names[@]}"

remote="${CAVESIM_REMOTE:-cavesim}"
for pair in "--scene:$scene" "--out:$out" "--session:$session" "--keys:$keys" \
            "--config:$zenoh_config" "--cave:$cave" "CAVESIM_REMOTE:$remote"; do
    value="${pair#*:}"
    [[ -z "$value" || "$value" =~ ^[A-Za-z0-9._/:@%+=,~-]+$ ]] \
        || die "${pair%%:*} '$value': only letters, digits and ._/:@%+=,~- (it may go through ssh)"
done
[[ "$session" =~ ^[A-Za-z0-9_-]{1,32}$ ]] \
    || die "argument --session: expected 1-32 letters, digits, '_' or '-', got '$session'"

# -- the commands -------------------------------------------------------------------------------

common=(--scene "$scene" --session "$session")
[ -z "$zenoh_config" ] || common+=(--config "$zenoh_config")
((!mixed)) || common+=(--mixed-hardware)
[ -n "$keys" ] || ((insecure)) || die "argument --hosts: messages cross a network unsigned;" \
    "give --keys DIR (made by \`cavesim keys --out DIR --walls ...\`), or --insecure to run" \
    "unsigned anyway"
node_list="$(IFS=,; echo "${node_names[*]}")"
master_command=("${master_via[@]}" "$remote" master --walls "$node_list" --frames "$frames"
                "${common[@]}" --listen "tcp/0.0.0.0:$master_port"
                --report "$out/report.json" --frame-log "$out/frames.log")
[ -z "$keys" ] || master_command+=(--key-file "$keys/master.key")
((!realtime)) || master_command+=(--realtime)
[ -z "$max_lag" ] || master_command+=(--max-lag "$max_lag")
node_command() {  # node_command I: the command of node I, in the global array `command`
    eval "command=(${node_vias[$1]})"
    command+=("$remote" node --node "${node_names[$1]}" "${common[@]}"
              --connect "tcp/$master_host:$master_port" --listen "tcp/0.0.0.0:0" --verbose)
    [ -z "$keys" ] || command+=(--key-file "$keys/wall-${node_names[$1]}.key")
    ((!display)) || command+=(--cave "$cave" --display)
}

if ((dry_run)); then
    echo "# master on $master_host:$master_port (hosts file line $master_line)"
    show "${master_via[@]}" mkdir -p "$out"
    show "${master_command[@]}"
    for i in "${!node_names[@]}"; do
        node_command "$i"
        echo "# node ${node_names[$i]} on ${node_hosts[$i]} (hosts file line ${node_lines[$i]})," \
             "output to $out/logs/${node_names[$i]}.log"
        show "${command[@]}"
    done
    exit 0
fi

# -- run: the master, then the nodes; wait for the master; stop what is left -------------------

set -m  # every background process gets a process group of its own, with SIGINT not ignored
master_pid="" node_pids=() interrupted=0
GRACE_TENTHS=100  # 10 s for a process to end by itself before it is interrupted, then killed

still_running() { kill -0 "$1" 2>/dev/null; }

any_running() {
    local pid
    for pid in "$@"; do
        if still_running "$pid"; then return 0; fi
    done
    return 1
}

end_within() {  # end_within TENTHS PID...: wait until the PIDs ended; 1 if some did not in time
    local tenths=$1
    shift
    while any_running "$@"; do
        ((tenths-- > 0)) || return 1
        sleep 0.1
    done
}

signal_nodes() {  # signal_nodes SIGNAL: to the process group of every node still running
    local pid
    for pid in "${node_pids[@]}"; do
        if still_running "$pid"; then kill -"$1" -- "-$pid" 2>/dev/null || true; fi
    done
}

stop_nodes() {  # on exit: the master has told the nodes to STOP; end whichever did not
    trap - INT TERM
    end_within $GRACE_TENTHS "${node_pids[@]}" && return 0
    echo "$me: interrupting the node processes still running" >&2
    signal_nodes INT
    end_within $((GRACE_TENTHS / 2)) "${node_pids[@]}" && return 0
    echo "$me: killing the node processes still running" >&2
    signal_nodes KILL
}

interrupt_master() {  # Ctrl-C or TERM: the master stops the cluster in order
    [ -n "$master_pid" ] || exit 130
    interrupted=1
    echo "$me: interrupted: stopping the master" >&2
    kill -INT -- "-$master_pid" 2>/dev/null || true
}

trap stop_nodes EXIT
trap interrupt_master INT TERM

echo "$me: master on $master_host:$master_port, nodes $node_list; node logs in $out/logs" >&2
mkdir -p "$out/logs"
"${master_via[@]}" mkdir -p "$out" </dev/null
"${master_command[@]}" </dev/null &
master_pid=$!
for i in "${!node_names[@]}"; do
    node_command "$i"
    "${command[@]}" </dev/null >"$out/logs/${node_names[$i]}.log" 2>&1 &
    node_pids+=($!)
done

# A trapped signal ends `wait` early, with 128 + the signal: then wait again for the
# master's own status (127: that status had been collected already, keep it).
status=""
while :; do
    if wait "$master_pid"; then code=0; else code=$?; fi
    if ((code == 127)) && [ -n "$status" ]; then break; fi
    status=$code
    ((interrupted)) || break
    interrupted=0
done
echo "$me: master exited with status $status; its report is $out/report.json on $master_host" >&2
exit "$status"

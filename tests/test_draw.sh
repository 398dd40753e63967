#!/bin/sh
# test_draw.sh: output.draw: the sampled frames in plots/draw.dat, the script plots/draw.gp, and
# with gnuplot on PATH snapshots.png and animation.gif (checked by their headers).
. "$MOREAU_SRCDIR/tests/tap.sh"
PY=/usr/bin/python3

# two disks and a block at rest on a floor; 20 steps, 4 snapshots (steps 0, 7, 13, 20) and a GIF
# frame every 5 steps (0, 5, 10, 15, 20): 7 frames drawn
cat > "$OUT/draw.cfg" <<'EOF'
title = "draw: two disks and a block on a floor";
bodies = (
  { name = "floor"; type = "plane"; point = [0.0, 0.0]; normal = [0.0, 1.0]; },
  { name = "d1"; type = "disk"; center = [0.0, 0.1]; radius = 0.1; density = 1000.0; body_force = [0.0, -9.81]; },
  { name = "d2"; type = "disk"; center = [0.5, 0.05]; radius = 0.05; density = 2000.0; body_force = [0.0, -9.81]; },
  { name = "block"; type = "polygon"; center = [1.0, 0.1]; size = [0.4, 0.2]; density = 500.0;
    body_force = [0.0, -9.81]; }
);
time = { scheme = "theta"; theta = 0.5; dt = 1.0e-3; steps = 20; };
contact = {
  solver = "nscd";
  pairs = ( { name = "p1"; slave = "d1"; master = "floor"; mu = 0.3; },
            { name = "p2"; slave = "d2"; master = "floor"; mu = 0.3; },
            { name = "p3"; slave = "block"; master = "floor"; mu = 0.3; } );
};
output = { draw = { frames = 4; every = 5; }; };
EOF
count() { c=$(grep -c "$2" "$1" 2>/dev/null); echo "${c:-0}"; }

p="$OUT/d/plots"
e=$("$MOREAU" run "$OUT/draw.cfg" --out "$OUT/d" 2>&1 >/dev/null); ok $? "run with output.draw"
ok $(test -s "$p/draw.dat" && test -s "$p/draw.gp"; echo $?) "plots/draw.dat and plots/draw.gp written"
is "$(count "$p/draw.dat" '^# frame ')" "7" "draw.dat: 7 frames (the union of snapshots 0, 7, 13, 20 and GIF steps 0, 5, .., 20)"
is "$(grep '^# frame ' "$p/draw.dat" | sed 's/.*step \([0-9]*\),.*/\1/' | tr '\n' ' ')" "0 5 7 10 13 15 20 " "draw.dat: the frames' steps"
is "$(count "$p/draw.dat" '^# circles') $(count "$p/draw.dat" '^# outlines') $(count "$p/draw.dat" '^# contact network') $(count "$p/draw.dat" '^# planes of frame')" \
   "7 7 7 7" "draw.dat: per frame a block of circles, of outlines, of contact lines, of planes"
is "$(count "$p/draw.gp" '# snapshot [0-9]*/4$') $(count "$p/draw.gp" '# gif [0-9]*/5$')" "4 5" "draw.gp: 4 snapshots and 5 GIF frames"
is "$(grep '# snapshot [0-9]' "$p/draw.gp" | sed "s/.*set title '\([^']*\)'.*/\1/" | tr '\n' ',')" \
   "t = 0 s,t = 0.007 s,t = 0.013 s,t = 0.02 s," "draw.gp: each snapshot titled with its time"
# the geometry of the first and last frames, by gnuplot's indexing (blocks between blank-line pairs)
cat > "$OUT/blocks.py" <<'EOF'
import sys
def blocks(path):
    text = open(path).read()
    text = text[text.index('# frame 0:'):].rstrip('\n')       # past the header comment
    out = []
    for b in text.split('\n\n\n'):
        rows = [l.split() for l in b.split('\n') if l and not l.startswith('#')]
        out.append([[float(x) for x in r] for r in rows if 'NaN' not in r])
    return out
EOF
dat() { "$PY" -c "import sys; sys.path.insert(0, '$OUT'); from blocks import *; B = blocks('$p/draw.dat'); $1"; }
is "$(dat "print(len(B))")" "28" "draw.dat: 3 blocks per frame and one of planes per frame (gnuplot's index 0 .. 27)"
is "$(dat "print(B[0])")" "[[0.0, 0.1, 0.1, 0.0], [0.5, 0.05, 0.05, 0.0]]" "frame 0: the disks as circles x y r and their speed"
is "$(dat "print(len(B[1]))")" "9" "frame 0 outlines: 2 radius lines (2 points) and the closed rectangle (5 points)"
is "$(dat "print(len(B[3 * 6 + 2]), max(r[4] for r in B[3 * 6 + 2]) > 300)")" "4 True" \
   "last frame: 4 contact lines (a disk each, the block's 2 corners), the largest rn > 300 N"
is "$(dat "print(sorted([round(x, 9) for x in r] for r in B[3 * 7 + 6]))")" "[[-0.165, 0.0], [1.265, 0.0]]" \
   "the floor of the last frame: clipped to the view (the bodies' bounding box and a 5% margin)"
if [ -n "$(command -v gnuplot)" ]; then
  ok $("$PY" -c "import sys; d = open('$p/snapshots.png', 'rb').read(); import struct; w, h = struct.unpack('>II', d[16:24])
print(0 if d[:8] == b'\\x89PNG\\r\\n\\x1a\\n' and d[12:16] == b'IHDR' and len(d) > 5000 and w > 200 and h > 200 else 1)" 2>/dev/null || echo 1) \
     "snapshots.png: a PNG, $(wc -c < "$p/snapshots.png") bytes"
  # a GIF's frames: walk its blocks (header, screen, colour tables, extensions, images)
  gif_frames() { "$PY" - "$1" <<'EOF'
import sys
d = open(sys.argv[1], 'rb').read()
assert d[:6] in (b'GIF89a', b'GIF87a')
i = 13 + (3 << ((d[10] & 7) + 1) if d[10] & 0x80 else 0)
n = 0
def skip(i):
    while d[i]: i += d[i] + 1
    return i + 1
while d[i] != 0x3B:
    if d[i] == 0x21: i = skip(i + 2)
    elif d[i] == 0x2C:
        f = d[i + 9]; i += 10 + (3 << ((f & 7) + 1) if f & 0x80 else 0); i = skip(i + 1); n += 1
    else: raise ValueError('bad block')
print(n)
EOF
  }
  is "$(gif_frames "$p/animation.gif" 2>/dev/null)" "5" "animation.gif: a GIF of 5 frames, $(wc -c < "$p/animation.gif") bytes"
  contains "$e" "drawings: 2 figures, 2 rendered" "the run reports 2 figures, 2 rendered"
else
  echo "ok $((tap_n + 1)) # SKIP snapshots.png: no gnuplot on PATH"; tap_n=$((tap_n + 1))
  echo "ok $((tap_n + 1)) # SKIP animation.gif: no gnuplot on PATH"; tap_n=$((tap_n + 1))
  echo "ok $((tap_n + 1)) # SKIP the figures rendered: no gnuplot on PATH"; tap_n=$((tap_n + 1))
fi

# without gnuplot on PATH: the data and the script only (ls for libtool's wrapper)
mkdir -p "$OUT/bin" && ln -s "$(command -v ls)" "$OUT/bin/ls"
e=$(PATH="$OUT/bin" "$MOREAU" run "$OUT/draw.cfg" --out "$OUT/n" --set output.draw.gif=true 2>&1 >/dev/null); ok $? "run without gnuplot on PATH"
ok $(test -s "$OUT/n/plots/draw.gp" && test ! -e "$OUT/n/plots/snapshots.png"; echo $?) "draw.gp written, nothing rendered"
contains "$e" "drawings: 2 figures, 0 rendered" "the run says 0 rendered"
contains "$e" "no gnuplot on PATH" "and why"

# gif = false: the snapshots only; a deformable body falling freely: its outline where it is
"$MOREAU" run "$OUT/draw.cfg" --out "$OUT/g" --set output.draw.gif=false --quiet; ok $? "run with gif = false"
is "$(count "$OUT/g/plots/draw.dat" '^# frame ') $(count "$OUT/g/plots/draw.gp" "set output 'animation.gif'")" "4 0" "gif = false: 4 frames, no GIF in draw.gp"
cat > "$OUT/fall.cfg" <<'EOF'
title = "draw: a deformable block falling";
bodies = ( { name = "b"; mesh = { generator = "rectangle"; origin = [0.0, 1.0]; size = [0.2, 0.1]; elements = [2, 1]; };
             material = { E = 1.0e6; nu = 0.3; rho = 1000.0; }; body_force = [0.0, -9.81]; } );
time = { scheme = "theta"; theta = 0.5; dt = 1.0e-2; steps = 10; };
output = { draw = { frames = 2; gif = false; box = [-0.5, 0.7, 0.0, 1.2]; }; };
EOF
"$MOREAU" run "$OUT/fall.cfg" --out "$OUT/f" --quiet; ok $? "run: a deformable block falling, output.draw with a box"
p="$OUT/f/plots"
is "$(dat "print(len(B), len(B[1]), len(B[4]))")" "8 12 12" "its outline: the 6 boundary edges of 2 x 1 Q4 elements, in both frames"
is "$(dat "print(round(min(r[1] for r in B[4]), 9))")" "$("$PY" -c "print(round(1.0 - 0.5 * 9.81 * 0.1**2, 9))")" \
   "the last frame's outline is the current configuration: y = 1 - g t^2 / 2 at t = 0.1"
contains "$(cat "$p/draw.gp")" "set xrange [-0.5:0.7]" "box: the view given"
printf 'output = { draw = { box = [1.0, 0.0, 0.0, 1.0]; }; };\n' > "$OUT/badbox.cfg"
sed '/^output/d' "$OUT/fall.cfg" >> "$OUT/badbox.cfg"
e=$("$MOREAU" run "$OUT/badbox.cfg" --out "$OUT/bb" 2>&1); is $? 2 "a box with xmin > xmax: exit 2"
contains "$e" "badbox.cfg:1: key 'output.draw.box': the view is [xmin, xmax, ymin, ymax]" "the message names file:line:key"
done_testing

"""anon_peak.py FILE CMD...: runs CMD, samples its anonymous resident size (RssAnon of
/proc/PID/status: the heap, the mapped arrays and the stack; not the pages of the program and its
libraries, whose count depends on the page cache's state and moves by 1 MB from run to run) every
2 ms, and writes the largest sample in bytes to FILE. Exits with CMD's status. Linux only; a peak
shorter than the sampling period can be missed (the figure is then a lower bound)."""
import subprocess, sys, time

out, cmd = sys.argv[1], sys.argv[2:]
p = subprocess.Popen(cmd)
peak = 0
path = '/proc/%d/status' % p.pid
while p.poll() is None:
    try:
        with open(path) as f:
            for line in f:
                if line.startswith('RssAnon:'):
                    peak = max(peak, 1024 * int(line.split()[1]))
                    break
    except (OSError, ValueError):
        pass
    time.sleep(0.002)
with open(out, 'w') as f:
    f.write('%d\n' % peak)
sys.exit(p.returncode)

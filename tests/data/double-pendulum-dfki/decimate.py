# Decimates the lab's six sys_id recordings to the columns drops needs, every second row; the
# torque of a kept row is the time-weighted mean of its own and the dropped row's, so that the
# torque held from row to row integrates to the original's over every 4 ms step.
import csv
# Usage (from the repository's root): python3 tests/data/double-pendulum-dfki/decimate.py LAB_DATA_DIR
import sys
SOURCE = sys.argv[1]  # the lab's data/system_identification folder (holding sys_id/)
D = 'tests/data/double-pendulum-dfki/'
for i in range(6):
    rows = list(csv.DictReader(open(SOURCE + '/sys_id/trajectory_%02d.csv' % i)))
    t = [float(r['time']) for r in rows]
    lines = ['time,pos_meas1,pos_meas2,tau_meas1,tau_meas2\n']
    for k in range(0, len(rows), 2):
        r = rows[k]
        tau = []
        for c in ('tau_meas1', 'tau_meas2'):
            if k + 2 < len(rows):
                a, b = t[k + 1] - t[k], t[k + 2] - t[k + 1]
                tau.append((float(r[c]) * a + float(rows[k + 1][c]) * b) / (a + b))
            else:
                tau.append(float(r[c]))
        lines.append('%.4f,%.5f,%.5f,%.4f,%.4f\n' % (t[k], float(r['pos_meas1']), float(r['pos_meas2']), tau[0], tau[1]))
    open(D + 'sys_id/trajectory_%02d.csv' % i, 'w').writelines(lines)
    if i in (0, 1):
        lim = 3.0 if i == 0 else 2.0
        name = 'trajectory_00_first3s.csv' if i == 0 else 'trajectory_01_first2s.csv'
        open(D + name, 'w').writelines([lines[0]] + [l for l in lines[1:] if float(l.split(',')[0]) <= lim])

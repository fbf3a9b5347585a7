#!/usr/bin/env python3
# Mutation audit of first_contact_time (src/edmd/contact_time.hpp; Engine::pair_time in
# src/edmd/engine.cpp until 852a9c1) and the air-table branch of Engine::scan_cell
# (docs/reviews/mutation-audit-pair-time.md). Each mutation is an exact
# text replacement (the old text must occur exactly once in the file); the runner applies one,
# rebuilds the targets that link engine.cpp, runs stage 1 and, for the stage-1 survivors,
# stage 2, writes the file back and checks it against git byte for byte.
#
#   python3 scripts/mutation-audit-pair-time.py [--list] [--full] [ID ...]   (from the worktree root,
#   Release build in build/, the tree committed: the files are compared with HEAD; results
#   appended to $RESULTS, default /tmp/mutpt/results.jsonl; logs in $LOGS)
import json, os, subprocess, sys, time

CT = 'src/edmd/contact_time.hpp'  # first_contact_time (Engine::pair_time before 852a9c1)
EN = 'src/edmd/engine.cpp'        # Engine::scan_cell, scan_neighbours

# (id, what the mutation does, old text, new text); the file is CT for T*, EN for S*, the line
# is where the old text starts
M = [
    # --- Engine::pair_time: the cheap rejection
    ('T1', 'rejection removed (never returns early on the gap)',
     'if (gap > reach) return never;', 'if (false && gap > reach) return never;'),
    ('T2', 'rejection with >= (a gap exactly equal to the reach rejected)',
     'if (gap > reach) return never;', 'if (gap >= reach) return never;'),
    ('T3', 'reach: the 0.5 of the acceleration term dropped (a looser bound)',
     '0.5 * std::sqrt(dot(da, da)) * tmax * tmax', 'std::sqrt(dot(da, da)) * tmax * tmax'),
    ('T4', 'reach: 0.25 instead of 0.5 (a bound too tight by half the acceleration term)',
     '0.5 * std::sqrt(dot(da, da)) * tmax * tmax', '0.25 * std::sqrt(dot(da, da)) * tmax * tmax'),
    ('T5', 'reach: the acceleration term dropped (ballistic bound)',
     ' + 0.5 * std::sqrt(dot(da, da)) * tmax * tmax;', ';'),
    ('T6', 'gap as |dr|^2 - 1 instead of |dr| - 1 (larger than the true gap)',
     'const double gap = std::sqrt(dot(dr, dr)) - 1.0;', 'const double gap = dot(dr, dr) - 1.0;'),
    ('T7', 'rejection also for tmax = inf (reach inf or NaN)',
     'if (std::isfinite(tmax)) {\n    const double reach', 'if (true) {\n    const double reach'),
    # --- the coefficients of f(t) = |dr + dv t + da t^2/2|^2 - 1
    ('T8', 's = da instead of da/2',
     'const Vec3 s = 0.5 * da;', 'const Vec3 s = da;'),
    ('T9', 'c3 = dv.s (factor 2 lost)',
     'p.c[3] = 2.0 * dot(dv, s);', 'p.c[3] = dot(dv, s);'),
    ('T10', 'c2 = dv.dv + dr.s (factor 2 lost on the acceleration term)',
     'p.c[2] = dot(dv, dv) + 2.0 * dot(dr, s);', 'p.c[2] = dot(dv, dv) + dot(dr, s);'),
    ('T11', 'c2 = dv.dv - 2 dr.s (sign of the acceleration term)',
     'p.c[2] = dot(dv, dv) + 2.0 * dot(dr, s);', 'p.c[2] = dot(dv, dv) - 2.0 * dot(dr, s);'),
    ('T12', 'c1 = dr.dv (factor 2 lost)',
     'p.c[1] = 2.0 * dot(dr, dv);', 'p.c[1] = dot(dr, dv);'),
    # --- the degree
    ('T13', 'degree always 4 (also when da = 0)',
     'p.deg = p.c[4] > 0.0 ? 4 : 2;', 'p.deg = 4;'),
    ('T14', 'degree choice on c4 >= 0',
     'p.deg = p.c[4] > 0.0 ? 4 : 2;', 'p.deg = p.c[4] >= 0.0 ? 4 : 2;'),
    ('T15', 'degree 4 only when c4 > 1e-12 (small relative accelerations taken as ballistic)',
     'p.deg = p.c[4] > 0.0 ? 4 : 2;', 'p.deg = p.c[4] > 1e-12 ? 4 : 2;'),
    # --- touching and approaching
    ('T16', 'touching and approaching: also c1 = 0 (no normal velocity) gives 0',
     'if (p.c[0] <= 0.0 && p.c[1] < 0.0) return 0.0;', 'if (p.c[0] <= 0.0 && p.c[1] <= 0.0) return 0.0;'),
    ('T17', 'touching and approaching: exact touching (c0 = 0) left out',
     'if (p.c[0] <= 0.0 && p.c[1] < 0.0) return 0.0;', 'if (p.c[0] < 0.0 && p.c[1] < 0.0) return 0.0;'),
    ('T18', 'touching and approaching: the shortcut removed',
     'if (p.c[0] <= 0.0 && p.c[1] < 0.0) return 0.0;', ''),
    # --- the horizon
    ('T19', 'horizon for tmax = inf: 1e3 instead of 1e6',
     'if (!std::isfinite(tmax)) tmax = 1e6;', 'if (!std::isfinite(tmax)) tmax = 1e3;'),
    ('T20', 'horizon for tmax = inf: 1e2 instead of 1e6',
     'if (!std::isfinite(tmax)) tmax = 1e6;', 'if (!std::isfinite(tmax)) tmax = 1e2;'),
    ('T21', 'horizon for tmax = inf: 10 instead of 1e6',
     'if (!std::isfinite(tmax)) tmax = 1e6;', 'if (!std::isfinite(tmax)) tmax = 10.0;'),
    # --- f non-decreasing for t >= 0: never a contact
    ('T22', 'early exit without the c3 condition',
     '&& p.c[2] >= 0.0 && p.c[3] >= 0.0) return never;', '&& p.c[2] >= 0.0) return never;'),
    ('T23', 'early exit without the c2 condition',
     '&& p.c[2] >= 0.0 && p.c[3] >= 0.0) return never;', '&& p.c[3] >= 0.0) return never;'),
    ('T24', 'early exit without the c1 condition',
     'p.c[0] > 0.0 && p.c[1] >= 0.0 && p.c[2]', 'p.c[0] > 0.0 && p.c[2]'),
    ('T25', 'early exit without the c0 condition',
     'if (p.c[0] > 0.0 && p.c[1] >= 0.0 && p.c[2]', 'if (p.c[1] >= 0.0 && p.c[2]'),
    ('T26', 'early exit removed',
     'if (p.c[0] > 0.0 && p.c[1] >= 0.0 && p.c[2] >= 0.0 && p.c[3] >= 0.0) return never;', ''),
    ('T27', 'early exit with c1 > 0 (a pair at its closest approach now not exited)',
     'p.c[0] > 0.0 && p.c[1] >= 0.0 && p.c[2]', 'p.c[0] > 0.0 && p.c[1] > 0.0 && p.c[2]'),
    # --- Engine::scan_cell, the air-table branch
    ('S1', 'horizon: the second candidate (best.t2 - t) instead of the first',
     'a_[j] - ai, best.t1 - t);', 'a_[j] - ai, best.t2 - t);'),
    ('S2', 'horizon: best.t1 (absolute time) instead of best.t1 - t',
     'a_[j] - ai, best.t1 - t);', 'a_[j] - ai, best.t1);'),
    ('S3', 'horizon: t - best.t1 (sign)',
     'a_[j] - ai, best.t1 - t);', 'a_[j] - ai, t - best.t1);'),
    ('S4', 'vj: the partner velocity not brought to t (kj.v)',
     'const Vec3 vj = kj.v + dtj * a_[j];', 'const Vec3 vj = kj.v;'),
    ('S5', 'vj: dtj with the wrong sign',
     'const Vec3 vj = kj.v + dtj * a_[j];', 'const Vec3 vj = kj.v - dtj * a_[j];'),
    ('S6', 'rj: the acceleration term dropped (ballistic position)',
     ' + (0.5 * dtj * dtj) * a_[j] + shift;', ' + shift;'),
    ('S7', 'rj: dtj^2 instead of dtj^2/2',
     '(0.5 * dtj * dtj) * a_[j] + shift;', '(dtj * dtj) * a_[j] + shift;'),
    ('S8', 'rj: the image shift with the wrong sign',
     '(0.5 * dtj * dtj) * a_[j] + shift;', '(0.5 * dtj * dtj) * a_[j] - shift;'),
    ('S9', 'relative acceleration with the wrong sign (ai - a_j)',
     'vj - ki.v, a_[j] - ai, best.t1 - t);', 'vj - ki.v, ai - a_[j], best.t1 - t);'),
    ('S10', 'no contact (+inf) offered anyway',
     '      if (!std::isfinite(tcol)) continue;\n', ''),
    ('S11', 'after the scan: the second candidate kept (not set to the first)',
     '    best.t2 = best.t1;\n    best.c2 = kUnknownCounter;', '    best.c2 = kUnknownCounter;'),
]

TARGETS = ['edmd_engine_test', 'edmd_contact_time_test', 'edmd_physics_test', 'edmd_transport_test',
           'edmd_restart_test']
# stage 1: the engine tests of the air table and the contact-time unit test (a second)
STAGE1 = [('edmd_engine_test', 'EdmdEngine.AirTable*:EdmdEngine.PairTime*'), ('edmd_contact_time_test', '*')]
# stage 2: every other default-tier test that runs an air-table engine (no other test reaches
# the mutated code: pair_time is called only when the heating is the air table)
STAGE2 = [('edmd_physics_test', 'EdmdPhysics.AirTable*'),
          ('edmd_transport_test', 'TransportForcing.*:TransportBookkeeping.*:TransportViscosity.*:TransportConductivity.*'),
          ('edmd_restart_test', 'EdmdRestart.AirTable*:EdmdRestart.Transport*')]


# --full: instead of stages 1 and 2, every default-tier test of the edmd label (the
# executables of tests/edmd rebuilt; about 70 s of tests at -j1 on the shared machine)
FULL_TARGETS = ['edmd_%s_test' % t for t in ('engine', 'physics', 'profile', 'walls', 'baths_guard', 'measure', 'calendar',
                                            'restart', 'transport', 'theory', 'rough', 'transport_exact', 'contact_time',
                                            'case_reader')] + ['edmd_queue_parity_calendar', 'edmd_queue_parity_heap']


def file_of(mid):
    return CT if mid.startswith('T') else EN


def line_of(src, old):
    return src[:src.index(old)].count('\n') + 1


def main():
    if '--list' in sys.argv:
        for mid, desc, old, new in M:
            src = open(file_of(mid)).read()
            assert src.count(old) == 1, mid
            print('%-4s %-26s %4d  %s' % (mid, file_of(mid), line_of(src, old), desc))
        return
    out = os.environ.get('RESULTS', '/tmp/mutpt/results.jsonl')
    logs = os.environ.get('LOGS', '/tmp/mutpt/logs')
    os.makedirs(logs, exist_ok=True)
    origs = {f: subprocess.run(['git', 'show', 'HEAD:' + f], capture_output=True, check=True).stdout for f in (CT, EN)}

    def sh(cmd, log, timeout=None):
        t0 = time.time()
        with open(log, 'w') as f:
            try:
                rc = subprocess.run(cmd, shell=True, stdout=f, stderr=subprocess.STDOUT, timeout=timeout).returncode
            except subprocess.TimeoutExpired:
                rc = 'timeout'
        return rc, time.time() - t0

    def failed(log):
        return [l.split()[3] for l in open(log, errors='replace') if l.startswith('[  FAILED  ]') and ' ms)' in l]

    def verify():
        for f, orig in origs.items():
            assert open(f, 'rb').read() == orig
            subprocess.run('git show HEAD:%s | cmp - %s' % (f, f), shell=True, check=True)

    def stage(runs, log):
        rc, dt, fails = 0, 0.0, []
        for k, (binary, filt) in enumerate(runs):
            r, d = sh("nice -n 10 timeout 120 build/tests/edmd/%s --gtest_filter='%s'" % (binary, filt), '%s.%d' % (log, k))
            dt += d
            if r != 0:
                rc = r
                fails += failed('%s.%d' % (log, k)) or ['%s (rc %s)' % (binary, r)]
        return [rc, round(dt, 1), fails]

    only = [a for a in sys.argv[1:] if not a.startswith('--')]
    for mid, desc, old, new in M:
        if only and mid not in only:
            continue
        verify()
        F = file_of(mid)
        orig = origs[F]
        src = orig.decode()
        assert src.count(old) == 1, mid
        res = {'id': mid, 'line': line_of(src, old), 'desc': desc}
        L = logs + '/' + mid
        open(F, 'w').write(src.replace(old, new))
        try:
            full = '--full' in sys.argv
            rc, dt = sh('nice -n 10 cmake --build build -j2 --target ' + ' '.join(FULL_TARGETS if full else TARGETS),
                        L + '.build')
            res['build'] = [rc, round(dt)]
            if rc != 0:
                res['result'] = 'compile error'
            elif full:
                r, d = sh('nice -n 10 ctest --test-dir build -L edmd -LE long -j1', L + '.full')
                fails = [l.split()[3] for l in open(L + '.full', errors='replace') if '***Failed' in l or '***Timeout' in l]
                res['full'] = [r, round(d), fails]
                res['result'] = 'killed (edmd label)' if r != 0 else 'SURVIVED (edmd label)'
            else:
                res['stage1'] = stage(STAGE1, L + '.stage1')
                if res['stage1'][0] == 0:
                    res['stage2'] = stage(STAGE2, L + '.stage2')
                res['result'] = ('killed stage 1' if res['stage1'][0] != 0 else
                                 'killed stage 2' if res['stage2'][0] != 0 else 'SURVIVED')
        finally:
            open(F, 'wb').write(orig)
            verify()
        print(json.dumps(res), flush=True)
        with open(out, 'a') as f:
            f.write(json.dumps(res) + '\n')


if __name__ == '__main__':
    main()

import sys, statistics as st
rows=[l.split() for l in open(sys.argv[1]) if 'round=' in l]
bins=[]
for r in rows:
    if r[3] not in bins: bins.append(r[3])
vals={b:[float(r[4]) for r in rows if r[3]==b] for b in bins}
base=bins[0]
for b in bins:
    print(b, 'n', len(vals[b]), 'median %.2f'%st.median(vals[b]), ' '.join('%.2f'%v for v in vals[b]))
for b in bins[1:]:
    d=[n-o for n,o in zip(vals[b],vals[base])]
    print(b,'vs',base,': faster in %d of %d, pair median %+.2f'%(sum(x<0 for x in d),len(d),st.median(d)), ' '.join('%+.2f'%x for x in d))

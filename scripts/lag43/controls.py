import json,glob,os,subprocess,csv,random
random.seed(43)
cands=[]
for j in sorted(glob.glob('/work/ev/l42b/grid/est/moving_traffic_*.jsonl')):
    name=os.path.basename(j)[:-6]
    pf=f'/tmp/t43/basepf_{name}.csv'
    if not os.path.exists(pf):
        subprocess.run(['/tmp/t43/momo','eval','--gt',f'/work/sets/family/{name}/poses.txt','--est',j[:-6]+'.txt','--per-frame',pf],stdout=subprocess.DEVNULL,check=True)
    err={int(r['frame']):float(r['f2f_rotation_deg']) for r in csv.DictReader(open(pf)) if r['f2f_rotation_deg']}
    for line in open(j):
        d=json.loads(line); k=d['frame']
        if k<3 or k>494: continue
        if d['status']=='weak' and (d.get('competing') or d.get('road_alternative')) and err.get(k,9)<0.3:
            cands.append((name,k,err[k]))
print(len(cands))
s=random.sample(cands,40)
with open('/tmp/t43/controls.txt','w') as f:
    for n,k,e in s: f.write(f'{n} {k}\n')

import json, os, subprocess, sys, csv
MOMO='/tmp/t43/momo'
FAM='/work/sets/family'
OUT='/tmp/t43/runs'
def run(seq, k, mode):
    tag=f"{seq}_{k}_{mode}"
    est=f"{OUT}/{tag}.txt"; dj=f"{OUT}/{tag}.jsonl"; ev=f"{OUT}/{tag}.ev"; pf=f"{OUT}/{tag}.pf"
    if not os.path.exists(pf):
        env=dict(os.environ, MOMO_T43_EV='1', MOMO_T43_STOP=str(k+5))
        if mode!='base': env['MOMO_T43_FORCE']=f"{k},{mode}"
        with open(ev,'w') as e:
            subprocess.run([MOMO,'run',f"{FAM}/{seq}",'-o',est,'--diagnostics',dj,'-q'],env=env,stderr=e)
        subprocess.run([MOMO,'eval','--gt',f"{FAM}/{seq}/poses.txt",'--est',est,'--per-frame',pf],stdout=subprocess.DEVNULL,check=True)
    err={}
    for r in csv.DictReader(open(pf)):
        if r['f2f_rotation_deg']: err[int(r['frame'])]=float(r['f2f_rotation_deg'])
    evd={}; forced=None
    for line in open(ev):
        p=line.split()
        if p[0]=='T43EV':
            f=int(p[1]); evd[f]=dict(status=p[2],reason=p[3],cost=float(p[4]),matches=int(p[5]),inl=int(p[6]),road=int(p[7]),sup=int(p[8]),comp=p[9]=='true',w=[float(x) for x in p[10:13]])
        elif p[0]=='T43FORCE': forced=p[-1]=='true'
    return dict(err=err,ev=evd,forced=forced)
if __name__=='__main__':
    jobs=[l.split() for l in open(sys.argv[1]) if l.strip()]
    res={}
    for seq,k in jobs:
        k=int(k); d={}
        for mode in ['base','comp','road','prev']:
            r=run(seq,k,mode)
            if mode!='base' and not r['forced']: continue
            d[mode]={'err':{f:r['err'][f] for f in range(k-2,k+6) if f in r['err']},'ev':{f:r['ev'][f] for f in range(k-2,k+6) if f in r['ev']}}
        res[f"{seq} {k}"]=d
        print(seq,k,' '.join(f"{m}:{d[m]['err'].get(k,float('nan')):.2f}/{d[m]['err'].get(k+1,float('nan')):.2f}" for m in d),flush=True)
    json.dump(res,open(sys.argv[2],'w'))

import json,sys
def road_sum(d,k,L):
    ev=d['ev']
    fr=[ev.get(str(j)) for j in range(k,k+L+1)]
    if any(x is None for x in fr): return None
    return sum(x['road'] for x in fr)
def apply(res,L,margin,ratio=1.0,modes=('comp','road','prev')):
    out=[]
    for case,d in res.items():
        seq,k=case.split(); k=int(k)
        rb=road_sum(d['base'],k,L)
        if rb is None: continue
        best='base'; bs=rb
        for m in modes:
            if m in d:
                r=road_sum(d[m],k,L)
                if r is not None and r>bs: best,bs=m,r
        if best!='base' and not (bs>=rb+margin and bs>ratio*rb): best='base'
        e0=d['base']['err'].get(str(k)); e1=d[best]['err'].get(str(k))
        s0=sum(d['base']['err'].get(str(j),0) for j in range(k,k+L+1)); s1=sum(d[best]['err'].get(str(j),0) for j in range(k,k+L+1))
        mx0=max(d['base']['err'].get(str(j),0) for j in range(k,k+L+1)); mx1=max(d[best]['err'].get(str(j),0) for j in range(k,k+L+1))
        out.append((case,best,e0,e1,s0,s1,mx0,mx1))
    return out
def summary(name,out):
    sw=[o for o in out if o[1]!='base']
    better=sum(o[3]<o[2]-0.1 for o in sw); worse=sum(o[3]>o[2]+0.1 for o in sw)
    sb=sum(o[5]<o[4]-0.1 for o in sw); swr=sum(o[5]>o[4]+0.1 for o in sw)
    g0=sum(o[6]>1 for o in out); g1=sum(o[7]>1 for o in out)
    return f"{name}: n {len(out)} switched {len(sw)}; at k better/worse {better}/{worse}; sum k..k+L better/worse {sb}/{swr}; cases with a frame >1 deg in k..k+L {g0} -> {g1}"
if __name__=='__main__':
    for path in sys.argv[1].split(','):
        res=json.load(open(path))
        for L in (1,2,3,5):
            for margin in (1,3,5):
                print(summary(f"{path} L={L} margin={margin}",apply(res,L,margin)))
        if len(sys.argv)>2:
            for o in apply(res,int(sys.argv[2]),int(sys.argv[3])):
                if o[1]!='base': print('  ',o[0],o[1],' '.join(f'{x:.2f}' for x in o[2:]))

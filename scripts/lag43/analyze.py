import json,sys,math
def metrics(d,k,L,base_prev_yaw):
    ev=d['ev']; err=d['err']
    g=lambda f:ev.get(str(f))
    out={}
    fr=[g(j) for j in range(k+1,k+L+1)]
    if any(x is None for x in fr) or g(k) is None: return None
    out['cost']=-sum(x['cost']/max(x['matches'],1) for x in fr)   # higher is better
    out['road']=sum(x['road'] for x in [g(k)]+fr)
    out['roadL']=sum(x['road'] for x in fr)
    out['sup']=sum(x['sup'] for x in fr)
    out['inl']=sum(x['inl'] for x in fr)
    out['unflag']=-sum(x['status']!='Estimated' for x in fr)
    out['nocomp']=-sum(x['comp'] for x in fr)
    ys=[base_prev_yaw]+[g(j)['w'][2] for j in range(k,k+L+1)]
    out['smooth']=-sum(abs(ys[i+1]-ys[i]) for i in range(len(ys)-1))
    # second difference (constant yaw rate)
    out['smooth2']=-sum(abs(ys[i+2]-2*ys[i+1]+ys[i]) for i in range(len(ys)-2))
    tx=[g(j)['w'][:2] for j in range(k,k+L+1)]
    out['tilt']=-sum(math.hypot(t[0]-tx[i][0],t[1]-tx[i][1]) for i,t in enumerate(tx[1:]))
    out['_errk']=err.get(str(k),float('nan'))
    out['_errsum']=sum(err.get(str(j),0) for j in range(k,k+L+1))
    return out
def analyze(path,L,verbose):
    res=json.load(open(path))
    keys=['cost','road','roadL','sup','inl','unflag','nocomp','smooth','smooth2','tilt']
    tally={e:[0,0,0] for e in keys}  # better, worse, same (vs base at k by >0.1 deg)
    rows=[]
    for case,d in res.items():
        seq,k=case.split(); k=int(k)
        by=d['base']['ev'].get(str(k-1))
        py=by['w'][2] if by else 0.0
        m={b:metrics(d[b],k,L,py) for b in d}
        if any(v is None for v in m.values()): continue
        base=m['base']
        line=[case]+[f"{b}:e{m[b]['_errk']:.2f}/s{m[b]['_errsum']:.2f}" for b in m]
        for e in keys:
            best=max(m, key=lambda b:(m[b][e], b=='base'))
            de=m[best]['_errk']-base['_errk']
            if de< -0.1: tally[e][0]+=1
            elif de>0.1: tally[e][1]+=1
            else: tally[e][2]+=1
            line.append(f"{e}->{best}")
        if verbose: print(' '.join(line))
    print(f"L={L} n={len(res)} evidence: better/worse/same at k (by 0.1 deg) vs main's choice")
    for e in keys: print(f"  {e:8s} {tally[e]}")
if __name__=='__main__':
    for L in map(int,sys.argv[2].split(',')): analyze(sys.argv[1],L,len(sys.argv)>3)

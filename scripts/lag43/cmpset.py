import sys,math,filecmp,os
def rows(p):
    d={}
    for l in open(p):
        f=l.rstrip('\n').split('\t')
        if f[0]=='name' or len(f)<5: continue
        try: d[f[0]]=(float(f[1]),int(f[2]),float(f[3]))
        except: pass
    return d
a=rows(sys.argv[1]+'/rows.tsv'); b=rows(sys.argv[2]+'/rows.tsv')
up=down=same=ident=0; mv=[]
for n in a:
    if n not in b: continue
    ea=a[n][0]/a[n][2]; eb=b[n][0]/b[n][2]
    fa=os.path.join(sys.argv[1],'est',n+'.txt'); fb=os.path.join(sys.argv[2],'est',n+'.txt')
    if os.path.exists(fa) and os.path.exists(fb) and filecmp.cmp(fa,fb,shallow=False): ident+=1
    if eb-ea>=0.005: up+=1; mv.append((n,round(ea,3),round(eb,3)))
    elif ea-eb>=0.005: down+=1; mv.append((n,round(ea,3),round(eb,3)))
    if a[n][1]!=b[n][1]: print('  >1deg',n,a[n][1],'->',b[n][1])
k=min(up,down); N=up+down
p=min(1,2*sum(math.comb(N,i) for i in range(k+1))/2**N) if N else 1
print(f"n {len(a)} identical {ident}; eff worse(up) {up} better(down) {down} p={p:.3g}; mean change {sum(b[n][0]/b[n][2]-a[n][0]/a[n][2] for n in a if n in b)/len(a):+.4f}")

import json,sys
import rule
def road_sum_after(d,k,L):
    ev=d['ev']
    fr=[ev.get(str(j)) for j in range(k+1,k+L+1)]
    if any(x is None for x in fr) or ev.get(str(k)) is None: return None
    return sum(x['road'] for x in fr)
orig=rule.road_sum
for path in sys.argv[1].split(','):
    res=json.load(open(path))
    rule.road_sum=orig
    print(rule.summary(f"{path} frame k alone (L=0) margin=3",rule.apply(res,0,3)))
    rule.road_sum=road_sum_after
    for L in (1,2,5):
        print(rule.summary(f"{path} later frames only L={L} margin=3",rule.apply(res,L,3)))
    rule.road_sum=orig

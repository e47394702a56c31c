import json,sys
from rule import apply,summary
for path in sys.argv[1].split(','):
    res=json.load(open(path))
    for modes in [('comp','road','prev'),('road','prev'),('prev',),('comp',),('road',)]:
        for L,m in [(1,3),(2,3),(5,3),(2,8)]:
            print(summary(f"{path} modes={'+'.join(modes)} L={L} margin={m}",apply(res,L,m,modes=modes)))
